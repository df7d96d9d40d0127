#include "engine/export/tum_trajectory.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "engine/core/error.h"

namespace glam {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// Each test writes into its own temporary folder, removed afterwards.
class TumTrajectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("glam_tum_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path TestFile(const std::string& name) const { return dir_ / name; }

  fs::path dir_;
};

void WriteText(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

// Message of the InputError thrown by reading `path`, or "" if none was thrown.
std::string ReadError(const fs::path& path) {
  try {
    ReadTumTrajectory(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST_F(TumTrajectoryTest, WriteReadRoundTrip) {
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<TimedPose> poses;
  for (int frame = 0; frame < 50; ++frame) {
    const Eigen::Vector3d omega(normal(rng), normal(rng), normal(rng));
    const Eigen::Vector3d t(100 * normal(rng), 100 * normal(rng), 50 + normal(rng));
    poses.push_back({frame / 29.97, SE3(SO3::Exp(omega), t)});
  }
  const fs::path path = TestFile("trajectory.tum");
  WriteTumTrajectory(path, poses);
  const std::vector<TimedPose> read = ReadTumTrajectory(path);
  ASSERT_EQ(read.size(), poses.size());
  for (std::size_t k = 0; k < poses.size(); ++k) {
    EXPECT_NEAR(read[k].timestamp, poses[k].timestamp, 1e-9);
    EXPECT_LT((read[k].world_from_cam.translation() - poses[k].world_from_cam.translation()).norm(),
              1e-5);
    const double angle =
        (read[k].world_from_cam.rotation().Inverse() * poses[k].world_from_cam.rotation())
            .Log()
            .norm();
    EXPECT_LT(angle, 1e-7);
  }
}

TEST_F(TumTrajectoryTest, ReadsColumnsInTumOrderAndSkipsComments) {
  const fs::path path = TestFile("trajectory.tum");
  // 90 degrees about z: q = (x, y, z, w) = (0, 0, sin 45, cos 45).
  const double s = std::sqrt(0.5);
  WriteText(path, "# timestamp tx ty tz qx qy qz qw\n\n0.5 1 2 3 0 0 " + std::to_string(s) + " " +
                      std::to_string(s) + "\n");
  const std::vector<TimedPose> read = ReadTumTrajectory(path);
  ASSERT_EQ(read.size(), 1u);
  EXPECT_DOUBLE_EQ(read[0].timestamp, 0.5);
  EXPECT_EQ(read[0].world_from_cam.translation(), Eigen::Vector3d(1, 2, 3));
  // world_from_cam maps the camera's x axis onto world +y.
  const Eigen::Vector3d x_in_world = read[0].world_from_cam.rotation() * Eigen::Vector3d::UnitX();
  EXPECT_LT((x_in_world - Eigen::Vector3d::UnitY()).norm(), 1e-6);
}

TEST_F(TumTrajectoryTest, MalformedLineIsReportedWithItsLineNumber) {
  const fs::path path = TestFile("bad.tum");
  WriteText(path, "# header\n0 0 0 0 0 0 0 1\n0.1 0 0 0 0 0 1\n");  // line 3 has 7 numbers
  const std::string message = ReadError(path);
  EXPECT_THAT(message, HasSubstr("bad.tum:3"));
  EXPECT_THAT(message, HasSubstr("8 numbers"));
}

TEST_F(TumTrajectoryTest, RejectsTrailingGarbageNonNumbersAndExtraColumns) {
  const fs::path path = TestFile("bad.tum");
  WriteText(path, "0 0 0 0 0 0 0 1\n0.1 0 0 zero 0 0 0 1\n");
  EXPECT_THAT(ReadError(path), HasSubstr("bad.tum:2"));
  WriteText(path, "0 0 0 0 0 0 0 1 5\n");
  EXPECT_THAT(ReadError(path), HasSubstr("bad.tum:1"));
}

TEST_F(TumTrajectoryTest, RejectsUnnormalisedAndNanQuaternions) {
  const fs::path path = TestFile("bad.tum");
  WriteText(path, "0 0 0 0 0 0 0 1\n0.1 0 0 0 0 0 0 2\n");
  const std::string message = ReadError(path);
  EXPECT_THAT(message, HasSubstr("bad.tum:2"));
  EXPECT_THAT(message, HasSubstr("norm"));
  WriteText(path, "0 0 0 0 nan 0 0 1\n");
  EXPECT_THAT(ReadError(path), HasSubstr("bad.tum:1"));
}

TEST_F(TumTrajectoryTest, MissingFileIsAnInputErrorNamingTheFile) {
  EXPECT_THAT(ReadError(TestFile("does_not_exist.tum")), HasSubstr("does_not_exist.tum"));
}

}  // namespace
}  // namespace glam
