#include "engine/geometry/rotation_only.h"

#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "tests/geometry/synthetic_scene.h"

namespace glam {
namespace {

using testing::RotationErrorDeg;

constexpr double kFocal = 554.0;  // 60 deg horizontal field of view at 640x360

// Ground points (relief +-6 m) seen by both cameras inside a 640x360 frame, observed with the
// true focal, 0.3 px noise (sub-pixel SIFT / KLT on sharp video), and normalised with
// `assumed_focal` (a focal still being estimated). The options are the bootstrap's (1 px).
std::vector<TwoViewCorrespondence> Observations(const SE3& cam1_from_world, const SE3& cam2_from_world,
                                                double assumed_focal, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.3);
  std::uniform_real_distribution<double> ground(-150.0, 150.0), relief(-6.0, 6.0);
  std::vector<TwoViewCorrespondence> data;
  auto pixel = [&](const SE3& cam_from_world, const Eigen::Vector3d& p, Eigen::Vector2d* out) {
    const Eigen::Vector3d c = cam_from_world * p;
    if (c.z() <= 1.0) return false;
    *out = kFocal * c.head<2>() / c.z();
    return std::abs(out->x()) < 320 && std::abs(out->y()) < 180;
  };
  for (int tries = 0; data.size() < 400 && tries < 200000; ++tries) {
    const Eigen::Vector3d p(ground(rng), ground(rng), relief(rng));
    Eigen::Vector2d u1, u2;
    if (!pixel(cam1_from_world, p, &u1) || !pixel(cam2_from_world, p, &u2)) continue;
    u1 += Eigen::Vector2d(noise(rng), noise(rng));
    u2 += Eigen::Vector2d(noise(rng), noise(rng));
    data.push_back({u1 / assumed_focal, u2 / assumed_focal});
  }
  return data;
}

// A drone hovering 60 m up with the camera 45 deg from nadir, yawing 15 deg in place: the
// rotation explains nearly every correspondence to within the noise, with the focal 8 % off
// as well (and finds it). The bootstrap's veto is at 0.8.
TEST(RotationOnly, AHoveringYawIsExplainedByARotationEvenWithTheFocalOff) {
  const SE3 cam1 = testing::DownwardCamera({0, 0, 60}, 0.0, 45.0);
  const SE3 cam2 = testing::DownwardCamera({0, 0, 60}, 15.0, 45.0);
  for (double assumed : {kFocal, 1.08 * kFocal, 0.92 * kFocal}) {
    const std::vector<TwoViewCorrespondence> data = Observations(cam1, cam2, assumed, 3);
    ASSERT_GT(data.size(), 200u);
    const RotationOnlyFit fit = FitRotationOnly(data, assumed);
    ASSERT_TRUE(fit.success);
    EXPECT_GT(fit.inlier_fraction, 0.85) << "assumed focal " << assumed;
    EXPECT_LT(RotationErrorDeg(fit.cam2_from_cam1, (cam2 * cam1.Inverse()).rotation()), 0.1);
    EXPECT_NEAR(fit.focal_scale * assumed, kFocal, 0.01 * kFocal) << "assumed focal " << assumed;
  }
}

// The same camera flying 4 m sideways and 2 m forward while yawing 5 deg (about 3 deg of
// parallax on the ground 85 m away): no rotation explains most of it.
TEST(RotationOnly, ARealBaselineOverRollingGroundIsNot) {
  const SE3 cam1 = testing::DownwardCamera({0, 0, 60}, 0.0, 45.0);
  const SE3 cam2 = testing::DownwardCamera({4, 2, 60}, 5.0, 45.0);
  const std::vector<TwoViewCorrespondence> data = Observations(cam1, cam2, kFocal, 4);
  ASSERT_GT(data.size(), 200u);
  const RotationOnlyFit fit = FitRotationOnly(data, kFocal);
  ASSERT_TRUE(fit.success);
  EXPECT_LT(fit.inlier_fraction, 0.3);
}

// Nadir over low relief is the case where translation and rotation look most alike (the flow
// of a small move is nearly a uniform shift); at a bootstrap's parallax (3.5 m at 100 m, 2 deg)
// the perspective of a 60-degree lens still leaves 1-2 px a rotation cannot absorb.
TEST(RotationOnly, NadirStepsAtBootstrapParallaxAreNot) {
  const SE3 cam1 = testing::DownwardCamera({0, 0, 100}, 0.0, 0.0);
  for (const Eigen::Vector3d& centre : {Eigen::Vector3d(3.5, 0, 100), Eigen::Vector3d(0, 3.5, 100)}) {
    const SE3 cam2 = testing::DownwardCamera(centre, 0.5, 0.0);
    const std::vector<TwoViewCorrespondence> data = Observations(cam1, cam2, kFocal, 5);
    ASSERT_GT(data.size(), 200u);
    const RotationOnlyFit fit = FitRotationOnly(data, kFocal);
    ASSERT_TRUE(fit.success);
    EXPECT_LT(fit.inlier_fraction, 0.6) << "step to " << centre.transpose();
  }
}

TEST(RotationOnly, FewerThanThreeCorrespondencesFail) {
  const std::vector<TwoViewCorrespondence> data = {{{0, 0}, {0.1, 0}}, {{0.2, 0.1}, {0.3, 0.1}}};
  EXPECT_FALSE(FitRotationOnly(data, kFocal).success);
}

TEST(RotationOnly, OptionsAreChecked) {
  RotationOnlyOptions options;
  options.inlier_threshold_px = 0;
  EXPECT_ANY_THROW(options.Check());
}

}  // namespace
}  // namespace glam
