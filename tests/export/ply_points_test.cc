#include "engine/export/ply_points.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

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
class PlyPointsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("glam_ply_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path TestFile(const std::string& name) const { return dir_ / name; }

  fs::path dir_;
};

std::string ReadError(const fs::path& path) {
  try {
    ReadPlyPoints(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

std::vector<ColoredPoint> RandomPoints(int n) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> coord(-500.0f, 500.0f);
  std::uniform_int_distribution<int> byte(0, 255);
  std::vector<ColoredPoint> points(n);
  for (ColoredPoint& p : points) {
    p.position = Eigen::Vector3f(coord(rng), coord(rng), coord(rng));
    for (auto& c : p.color) c = static_cast<std::uint8_t>(byte(rng));
  }
  return points;
}

TEST_F(PlyPointsTest, BinaryRoundTripIsExact) {
  const std::vector<ColoredPoint> points = RandomPoints(70000);  // more than one read chunk
  const fs::path path = TestFile("points.ply");
  WritePlyPoints(path, points);
  // Contract layout: 15 bytes per vertex after the header.
  std::ifstream in(path, std::ios::binary);
  std::string header, line;
  while (std::getline(in, line) && line != "end_header") header += line + "\n";
  EXPECT_THAT(header, HasSubstr("format binary_little_endian 1.0\nelement vertex 70000\n"
                                "property float x\nproperty float y\nproperty float z\n"
                                "property uchar red\nproperty uchar green\nproperty uchar blue\n"));
  EXPECT_EQ(fs::file_size(path) - static_cast<std::uintmax_t>(in.tellg()), 70000u * 15u);

  const std::vector<ColoredPoint> read = ReadPlyPoints(path);
  ASSERT_EQ(read.size(), points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    ASSERT_EQ(read[k].position, points[k].position) << k;
    ASSERT_EQ(read[k].color, points[k].color) << k;
  }
}

TEST_F(PlyPointsTest, EmptyCloudRoundTrips) {
  const fs::path path = TestFile("points.ply");
  WritePlyPoints(path, {});
  EXPECT_TRUE(ReadPlyPoints(path).empty());
}

TEST_F(PlyPointsTest, ReadsAsciiWithTheSameProperties) {
  const fs::path path = TestFile("points.ply");
  std::ofstream(path) << "ply\nformat ascii 1.0\ncomment by hand\nelement vertex 2\n"
                         "property float x\nproperty float y\nproperty float z\n"
                         "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                         "end_header\n1.5 -2 3 255 0 7\n0 0 10.25 1 2 3\n";
  const std::vector<ColoredPoint> read = ReadPlyPoints(path);
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(read[0].position, Eigen::Vector3f(1.5f, -2.0f, 3.0f));
  EXPECT_EQ(read[0].color, (std::array<std::uint8_t, 3>{255, 0, 7}));
  EXPECT_EQ(read[1].position, Eigen::Vector3f(0.0f, 0.0f, 10.25f));
}

TEST_F(PlyPointsTest, RejectsOtherLayoutsWithAClearMessage) {
  const fs::path path = TestFile("points.ply");
  const std::string props =
      "property float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  std::ofstream(path) << "ply\nformat binary_big_endian 1.0\nelement vertex 0\n"
                      << props << "end_header\n";
  EXPECT_THAT(ReadError(path), HasSubstr("binary_big_endian"));
  std::ofstream(path) << "ply\nformat binary_little_endian 1.0\nelement vertex 0\n"
                         "property double x\nproperty double y\nproperty double z\nend_header\n";
  EXPECT_THAT(ReadError(path), HasSubstr("property double x"));
  std::ofstream(path) << "ply\nformat binary_little_endian 1.0\nelement vertex 0\n"
                      << props
                      << "element face 0\nproperty list uchar int vertex_indices\nend_header\n";
  EXPECT_THAT(ReadError(path), HasSubstr("element 'face'"));
  std::ofstream(path) << "not a ply\n";
  EXPECT_THAT(ReadError(path), HasSubstr("not a PLY file"));
}

TEST_F(PlyPointsTest, RejectsTruncatedBody) {
  const fs::path path = TestFile("points.ply");
  WritePlyPoints(path, RandomPoints(10));
  fs::resize_file(path, fs::file_size(path) - 4);
  EXPECT_THAT(ReadError(path), HasSubstr("truncated"));
}

TEST_F(PlyPointsTest, MissingFileIsAnInputError) {
  EXPECT_THAT(ReadError(TestFile("none.ply")), HasSubstr("none.ply"));
}

}  // namespace
}  // namespace glam
