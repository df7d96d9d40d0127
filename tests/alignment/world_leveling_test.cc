// Levelling must make a tilted ground plane horizontal (z = 0) with the cameras above it,
// whatever the first submap's arbitrary orientation, and ignore off-plane structure.
#include "engine/alignment/world_leveling.h"

#include <random>

#include <gtest/gtest.h>

namespace glam {
namespace {

TEST(WorldLeveling, TiltedPlaneBecomesHorizontalWithCamerasAbove) {
  for (int flip = 0; flip < 2; ++flip) {
    std::mt19937 rng(9 + flip);
    std::uniform_real_distribution<double> u(-50, 50);
    std::normal_distribution<double> noise(0, 0.05);
    // submap_from_level: an arbitrary tilt; for flip = 1 the cameras are on the -z side of the
    // submap frame, which levelling must turn upwards.
    const SO3 tilt = SO3::Exp(Eigen::Vector3d(0.7, -0.4, 0.9 + 2.0 * flip));
    const Sim3 submap_from_level(0.3, tilt, Eigen::Vector3d(5, -3, 8));
    const double cam_height = flip == 0 ? 60.0 : -60.0;
    std::vector<Eigen::Vector3d> points, cameras;
    for (int i = 0; i < 400; ++i) points.push_back(submap_from_level * Eigen::Vector3d(u(rng), u(rng), noise(rng)));
    for (int i = 0; i < 60; ++i) {  // a "building": off-plane outliers
      points.push_back(submap_from_level * Eigen::Vector3d(u(rng) * 0.1 + 10, u(rng) * 0.1, 5 + std::abs(u(rng)) * 0.3));
    }
    for (int i = 0; i < 10; ++i) cameras.push_back(submap_from_level * Eigen::Vector3d(i * 5.0, 2, cam_height));

    const LevelingResult r = LevelGround(points, cameras);
    ASSERT_TRUE(r.levelled);
    EXPECT_GE(r.plane_inliers, 390);
    EXPECT_DOUBLE_EQ(r.world_from_submap.scale(), 1.0);
    // Ground points end at z ~ 0 (noise 0.05 level units = 0.015 submap units).
    double max_abs_z = 0;
    for (int i = 0; i < 400; ++i) max_abs_z = std::max(max_abs_z, std::abs((r.world_from_submap * points[i]).z()));
    EXPECT_LT(max_abs_z, 0.1);
    for (const auto& c : cameras) EXPECT_NEAR((r.world_from_submap * c).z(), 60 * 0.3, 0.1);
    const Eigen::Vector3d first = r.world_from_submap * cameras.front();
    EXPECT_NEAR(first.x(), 0, 1e-9);
    EXPECT_NEAR(first.y(), 0, 1e-9);
  }
}

TEST(WorldLeveling, TooFewPointsGivesIdentity) {
  const LevelingResult r = LevelGround({Eigen::Vector3d(0, 0, 0)}, {Eigen::Vector3d(0, 0, 1)});
  EXPECT_FALSE(r.levelled);
  EXPECT_TRUE(r.world_from_submap.matrix().isIdentity());
}

}  // namespace
}  // namespace glam
