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

// Under a nadir first camera the ground's normal (towards the cameras) is nearly opposite to the
// submap's z axis, where the shortest rotation to +z has no stable yaw. The yaw must follow the
// first camera's x axis instead: planes a degree apart give worlds a degree apart, not tens.
TEST(WorldLeveling, YawFollowsTheFirstCameraUnderANadirView) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-40, 40);
  const Eigen::Vector3d camera(0, 0, 0);  // the submap frame is the first camera's (z down to the ground)
  for (const Eigen::Vector3d& tilt_axis : {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(1, 1, 0)}) {
    std::vector<Sim3> levelled;
    for (const double tilt_deg : {0.0, 0.5, 1.0}) {
      const SO3 tilt(Eigen::Matrix3d(Eigen::AngleAxisd(tilt_deg * M_PI / 180, tilt_axis.normalized())));
      std::vector<Eigen::Vector3d> points;
      for (int i = 0; i < 300; ++i) points.push_back(tilt * Eigen::Vector3d(u(rng), u(rng), 50));
      const LevelingResult r = LevelGround(points, {camera, Eigen::Vector3d(3, 0, 0)});
      ASSERT_TRUE(r.levelled);
      levelled.push_back(r.world_from_submap);
      // The camera's x axis (image right) points along world +x, level.
      const Eigen::Vector3d x_in_world = r.world_from_submap.rotation() * Eigen::Vector3d::UnitX();
      EXPECT_GT(x_in_world.x(), 0.999) << tilt_deg;
      // Cameras above the ground, looking down.
      EXPECT_LT((r.world_from_submap.rotation() * Eigen::Vector3d::UnitZ()).z(), -0.99);
    }
    for (std::size_t i = 1; i < levelled.size(); ++i) {
      const double angle_deg = (levelled[i].rotation() * levelled[0].rotation().Inverse()).Log().norm() * 180 / M_PI;
      EXPECT_LT(angle_deg, 1.1) << "planes " << i * 0.5 << " degrees apart";
    }
  }
}

TEST(WorldLeveling, TooFewPointsGivesIdentity) {
  const LevelingResult r = LevelGround({Eigen::Vector3d(0, 0, 0)}, {Eigen::Vector3d(0, 0, 1)});
  EXPECT_FALSE(r.levelled);
  EXPECT_TRUE(r.world_from_submap.matrix().isIdentity());
}

}  // namespace
}  // namespace glam
