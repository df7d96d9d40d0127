#include "tools/synth/ground_truth_writer.h"

#include <fstream>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "engine/core/error.h"

namespace glam::synth {

void WriteTumTrajectory(const std::vector<SE3>& world_from_cam, double fps,
                        const std::filesystem::path& path) {
  std::ofstream out(path);
  for (std::size_t i = 0; i < world_from_cam.size(); ++i) {
    const Eigen::Vector3d& t = world_from_cam[i].translation();
    const Eigen::Quaterniond& q = world_from_cam[i].rotation().quaternion();
    out << fmt::format("{:.6f} {:.9f} {:.9f} {:.9f} {:.12f} {:.12f} {:.12f} {:.12f}\n",
                       static_cast<double>(i) / fps, t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w());
  }
  if (!out) throw EnvironmentError("cannot write " + path.string());
}

std::vector<SE3> ReadTumTrajectory(const std::filesystem::path& path, std::vector<double>* times) {
  std::ifstream in(path);
  if (!in) throw InputError("cannot read " + path.string());
  std::vector<SE3> poses;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    double t, x, y, z, qx, qy, qz, qw;
    if (!(fields >> t >> x >> y >> z >> qx >> qy >> qz >> qw)) {
      throw InputError(fmt::format("{}:{}: expected 't tx ty tz qx qy qz qw'", path.string(), number));
    }
    if (times != nullptr) times->push_back(t);
    poses.emplace_back(SO3(Eigen::Quaterniond(qw, qx, qy, qz)), Eigen::Vector3d(x, y, z));
  }
  return poses;
}

void WriteJson(const nlohmann::json& json, const std::filesystem::path& path) {
  std::ofstream out(path);
  out << json.dump(2) << "\n";
  if (!out) throw EnvironmentError("cannot write " + path.string());
}

}  // namespace glam::synth
