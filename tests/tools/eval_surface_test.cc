// Point-to-surface distance on analytic heightfields with known exact answers.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "engine/core/error.h"
#include "tests/tools/eval_test_world.h"
#include "tools/eval/ground_truth_surface.h"

namespace glam::eval {
namespace {

using testing::TempDir;
using testing::WriteHeightfieldByHand;

// Exact distance in the x-z plane from (x, z) to segment (ax, az)-(bx, bz).
double SegmentDistance2d(double x, double z, double ax, double az, double bx, double bz) {
  const Eigen::Vector2d a(ax, az), b(bx, bz), p(x, z);
  const double s = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
  return (a + s * (b - a) - p).norm();
}

TEST(GroundTruthSurface, LoadsTheContractLayoutRowMajor) {
  TempDir dir;
  // Non-square grid with heights that identify their (i, j): z = 10 i + j.
  const Eigen::Vector2d origin(-3.0, 7.5);
  WriteHeightfieldByHand(dir.path(), origin, 0.5, 5, 3, [&](double x, double y) {
    return 10 * std::round((x - origin.x()) / 0.5) + std::round((y - origin.y()) / 0.5);
  });
  const HeightfieldSurface s = HeightfieldSurface::Load(dir / "gt_surface.json");
  EXPECT_EQ(s.cols(), 5);
  EXPECT_EQ(s.rows(), 3);
  EXPECT_EQ(s.height(4, 2), 42.0f);
  EXPECT_EQ(s.height(3, 1), 31.0f);
  EXPECT_DOUBLE_EQ(s.HeightAt(-3.0 + 4 * 0.5, 7.5 + 2 * 0.5), 42.0);
  // Interior point: linear along x and y inside the cell's triangles.
  EXPECT_NEAR(s.HeightAt(-3.0 + 1.5 * 0.5, 7.5 + 0.25 * 0.5), 15.25, 1e-9);
  EXPECT_TRUE(s.Contains(-3.0, 7.5));
  EXPECT_FALSE(s.Contains(-3.01, 7.5));
  EXPECT_FALSE(s.Contains(-1.0, 8.51));
}

TEST(GroundTruthSurface, RejectsInconsistentFiles) {
  TempDir dir;
  WriteHeightfieldByHand(dir.path(), {0, 0}, 1.0, 4, 4, [](double, double) { return 0.0; });
  std::filesystem::resize_file(dir / "heights.bin", 4 * 4 * 4 - 4);
  try {
    HeightfieldSurface::Load(dir / "gt_surface.json");
    FAIL() << "short heights file accepted";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), ::testing::HasSubstr("heights.bin"));
  }
  EXPECT_THROW(HeightfieldSurface::Load(dir / "missing.json"), InputError);
}

TEST(GroundTruthSurface, FlatPlaneDistanceIsTheVerticalDistance) {
  const HeightfieldSurface s({0, 0}, 2.0, 30, 30, std::vector<float>(900, 12.5f));
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> xy(0.0, 58.0), z(-40.0, 60.0);
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector3d p(xy(rng), xy(rng), z(rng));
    const SurfaceDistance d = s.Distance(p);
    ASSERT_TRUE(d.inside);
    ASSERT_NEAR(d.distance, std::abs(p.z() - 12.5), 1e-9) << p.transpose();
  }
}

TEST(GroundTruthSurface, TiltedPlaneDistanceIsThePerpendicularDistance) {
  // z = 0.3 x - 0.2 y + 4, normal (-0.3, 0.2, 1).
  const auto plane = [](double x, double y) { return 0.3 * x - 0.2 * y + 4; };
  std::vector<float> heights;
  for (int j = 0; j < 41; ++j) {
    for (int i = 0; i < 41; ++i) heights.push_back(static_cast<float>(plane(i, j)));
  }
  const HeightfieldSurface s({0, 0}, 1.0, 41, 41, heights);
  const Eigen::Vector3d n = Eigen::Vector3d(-0.3, 0.2, 1).normalized();
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> xy(15.0, 25.0), off(-5.0, 5.0);
  for (int k = 0; k < 200; ++k) {
    const double x = xy(rng), y = xy(rng), o = off(rng);
    const Eigen::Vector3d p = Eigen::Vector3d(x, y, plane(x, y)) + o * n;
    ASSERT_NEAR(s.Distance(p).distance, std::abs(o), 1e-5) << p.transpose();  // float heights
  }
}

TEST(GroundTruthSurface, NextToAStepTheDistanceIsHorizontalToTheWall) {
  // Ground at z = 0 for x < 10, a 10 m high block for x >= 10; cell 0.1 m, so the wall is
  // the ramp between x = 9.9 and x = 10.0.
  const double c = 0.1;
  std::vector<float> heights;
  const int cols = 201, rows = 51;
  for (int j = 0; j < rows; ++j) {
    for (int i = 0; i < cols; ++i) heights.push_back(i * c >= 10.0 - 1e-9 ? 10.0f : 0.0f);
  }
  const HeightfieldSurface s({0, 0}, c, cols, rows, heights);
  // Exact answer from the x-z cross-section (the surface is constant along y).
  const auto expected = [](double x, double z) {
    return std::min({SegmentDistance2d(x, z, 0, 0, 9.9, 0), SegmentDistance2d(x, z, 9.9, 0, 10, 10),
                     SegmentDistance2d(x, z, 10, 10, 20, 10)});
  };
  // 2 m in front of the wall at half its height: ~2 m, not the 5 m to the ground below.
  const SurfaceDistance wall = s.Distance({7.95, 2.5, 5.0});
  EXPECT_NEAR(wall.distance, expected(7.95, 5.0), 1e-9);
  EXPECT_NEAR(wall.distance, 2.0, 0.06);
  EXPECT_NEAR(wall.closest.z(), 5.0, 0.1);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> x(1.0, 19.0), y(0.0, 5.0), z(-3.0, 15.0);
  for (int k = 0; k < 300; ++k) {
    const Eigen::Vector3d p(x(rng), y(rng), z(rng));
    ASSERT_NEAR(s.Distance(p).distance, expected(p.x(), p.z()), 1e-6) << p.transpose();
  }
}

TEST(GroundTruthSurface, SearchMatchesBruteForceOnABumpyField) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<float> bump(-3.0f, 3.0f);
  const int cols = 25, rows = 20;
  std::vector<float> heights(cols * rows);
  for (float& h : heights) h = bump(rng);
  const HeightfieldSurface s({-5, 2}, 0.7, cols, rows, heights);
  const auto brute_force = [&](const Eigen::Vector3d& p) {
    double best = std::numeric_limits<double>::infinity();
    const auto v = [&](int i, int j) {
      return Eigen::Vector3d(-5 + 0.7 * i, 2 + 0.7 * j, s.height(i, j));
    };
    for (int j = 0; j + 1 < rows; ++j) {
      for (int i = 0; i + 1 < cols; ++i) {
        for (const Eigen::Vector3d& q :
             {ClosestPointOnTriangle(p, v(i, j), v(i + 1, j), v(i + 1, j + 1)),
              ClosestPointOnTriangle(p, v(i, j), v(i + 1, j + 1), v(i, j + 1))}) {
          best = std::min(best, (q - p).norm());
        }
      }
    }
    return best;
  };
  std::uniform_real_distribution<double> x(-5.0, -5.0 + 0.7 * 24), y(2.0, 2.0 + 0.7 * 19),
      z(-8.0, 30.0);  // up to ~27 m above the bumps: the search radius must grow
  for (int k = 0; k < 300; ++k) {
    const Eigen::Vector3d p(x(rng), y(rng), z(rng));
    ASSERT_NEAR(s.Distance(p).distance, brute_force(p), 1e-9) << p.transpose();
  }
}

TEST(GroundTruthSurface, ClosestPointOnTriangleCoversFaceEdgeAndVertex) {
  const Eigen::Vector3d a(0, 0, 0), b(2, 0, 0), c(0, 2, 0);
  EXPECT_EQ(ClosestPointOnTriangle({0.5, 0.5, 3}, a, b, c), Eigen::Vector3d(0.5, 0.5, 0));
  EXPECT_LT((ClosestPointOnTriangle({1, -1, 1}, a, b, c) - Eigen::Vector3d(1, 0, 0)).norm(), 1e-12);
  EXPECT_LT((ClosestPointOnTriangle({2, 2, 0}, a, b, c) - Eigen::Vector3d(1, 1, 0)).norm(), 1e-12);
  EXPECT_EQ(ClosestPointOnTriangle({-1, -1, -1}, a, b, c), a);
  EXPECT_EQ(ClosestPointOnTriangle({5, -1, 0}, a, b, c), b);
}

TEST(GroundTruthSurface, PointsOutsideTheFootprintAreReportedAsOutside) {
  const HeightfieldSurface s({0, 0}, 1.0, 10, 10, std::vector<float>(100, 0.0f));
  EXPECT_FALSE(s.Distance({-0.5, 3, 0}).inside);
  EXPECT_FALSE(s.Distance({3, 9.5, 0}).inside);
  EXPECT_FALSE(s.Distance({std::nan(""), 3, 0}).inside);
  EXPECT_TRUE(s.Distance({9, 9, 1}).inside);
}

}  // namespace
}  // namespace glam::eval
