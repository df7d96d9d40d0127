#include "engine/export/tum_trajectory.h"

#include <fmt/format.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "engine/core/error.h"

namespace glam {
namespace {

// Norm tolerance for stored quaternions: loose enough for 6-decimal files written by other
// tools, tight enough to catch a wrong column order or a hand-edited value.
constexpr double kQuaternionNormTolerance = 1e-4;

bool IsBlankOrComment(const std::string& line) {
  const auto first = line.find_first_not_of(" \t\r");
  return first == std::string::npos || line[first] == '#';
}

TimedPose ParseLine(const std::string& line, const std::string& where) {
  std::istringstream in(line);
  double v[8];
  for (int k = 0; k < 8; ++k) {
    if (!(in >> v[k])) {
      throw InputError(
          fmt::format("{}: expected 8 numbers 't tx ty tz qx qy qz qw', got '{}'", where, line));
    }
  }
  std::string extra;
  if (in >> extra) {
    throw InputError(
        fmt::format("{}: expected 8 numbers 't tx ty tz qx qy qz qw', found extra "
                    "'{}'",
                    where, extra));
  }
  for (double x : v) {
    if (!std::isfinite(x)) throw InputError(fmt::format("{}: value is not finite", where));
  }
  const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);  // Eigen's constructor is (w, x, y, z).
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > kQuaternionNormTolerance) {
    throw InputError(
        fmt::format("{}: quaternion (qx qy qz qw) has norm {}, expected 1", where, norm));
  }
  return TimedPose{v[0], SE3(SO3(q), Eigen::Vector3d(v[1], v[2], v[3]))};
}

}  // namespace

std::vector<TimedPose> ReadTumTrajectory(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("cannot open trajectory {}", path.string()));
  std::vector<TimedPose> poses;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (IsBlankOrComment(line)) continue;
    poses.push_back(ParseLine(line, fmt::format("{}:{}", path.string(), line_number)));
  }
  if (in.bad()) throw InputError(fmt::format("cannot read trajectory {}", path.string()));
  return poses;
}

void WriteTumTrajectory(const std::filesystem::path& path, const std::vector<TimedPose>& poses) {
  std::FILE* f = std::fopen(path.string().c_str(), "w");
  if (f == nullptr) throw EnvironmentError(fmt::format("cannot write {}", path.string()));
  bool ok = true;
  for (const TimedPose& p : poses) {
    const Eigen::Vector3d& t = p.world_from_cam.translation();
    const Eigen::Quaterniond& q = p.world_from_cam.rotation().quaternion();
    ok = ok && std::fprintf(f, "%.9f %.12g %.12g %.12g %.12g %.12g %.12g %.12g\n", p.timestamp, t.x(),
                            t.y(), t.z(), q.x(), q.y(), q.z(), q.w()) > 0;
  }
  ok = (std::fclose(f) == 0) && ok;
  if (!ok) throw EnvironmentError(fmt::format("write failed for {} (disk full?)", path.string()));
}

}  // namespace glam
