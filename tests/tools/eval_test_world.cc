#include "tests/tools/eval_test_world.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

namespace glam::eval::testing {

namespace fs = std::filesystem;

std::vector<TimedPose> MakeGroundTruthTrajectory(int frames, double fps) {
  // Camera looking straight down: cam x -> world x, cam y -> world -y, cam z -> world -z.
  Eigen::Matrix3d down;
  down << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  std::vector<TimedPose> poses;
  for (int f = 0; f < frames; ++f) {
    const double t = f / fps;
    const Eigen::Vector3d centre(40 * std::cos(0.2 * t), 30 * std::sin(0.3 * t),
                                 50 + 3 * std::sin(0.5 * t));
    const SO3 yaw = SO3::Exp(Eigen::Vector3d(0, 0, 0.15 * t));
    const SO3 tilt = SO3::Exp(Eigen::Vector3d(0.1 * std::sin(0.7 * t), 0.05, 0));
    poses.push_back({t, SE3(yaw * tilt * SO3(down), centre)});
  }
  return poses;
}

std::vector<TimedPose> TransformPoses(const Sim3& estimate_from_gt,
                                      const std::vector<TimedPose>& poses) {
  std::vector<TimedPose> out;
  for (const TimedPose& p : poses) {
    out.push_back({p.timestamp, SE3(estimate_from_gt.rotation() * p.world_from_cam.rotation(),
                                    estimate_from_gt * p.world_from_cam.translation())});
  }
  return out;
}

void WriteHeightfieldByHand(const fs::path& dir, const Eigen::Vector2d& origin, double cell_size,
                            int cols, int rows,
                            const std::function<double(double, double)>& height) {
  std::vector<float> heights;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) {
      heights.push_back(
          static_cast<float>(height(origin.x() + i * cell_size, origin.y() + j * cell_size)));
    }
  }
  std::ofstream(dir / "heights.bin", std::ios::binary)
      .write(reinterpret_cast<const char*>(heights.data()),
             static_cast<std::streamsize>(heights.size() * sizeof(float)));
  const nlohmann::json meta = {
      {"format", "glam-heightfield"}, {"version", 1}, {"origin", {origin.x(), origin.y()}},
      {"cell_size", cell_size},       {"cols", cols}, {"rows", rows},
      {"heights", "heights.bin"}};
  std::ofstream(dir / "gt_surface.json") << meta.dump(2);
}

void WriteSynthJson(const fs::path& dir, double fps) {
  std::ofstream(dir / "synth.json") << nlohmann::json{{"fps", fps}, {"frames", 0}}.dump();
}

TempDir::TempDir() {
  static int counter = 0;  // several directories per test
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  path_ = fs::temp_directory_path() /
          ("glam_eval_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" +
           std::to_string(getpid()) + "_" + std::to_string(counter++));
  fs::remove_all(path_);
  fs::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

}  // namespace glam::eval::testing
