#include <random>

#include <gtest/gtest.h>

#include "engine/core/camera.h"
#include "engine/geometry/absolute_pose.h"
#include "engine/geometry/triangulation.h"
#include "tests/geometry/synthetic_scene.h"

namespace glam {
namespace {

using testing::RotationErrorDeg;

constexpr double kFocal = 800.0;

struct PnPScene {
  SE3 cam_from_world;
  std::vector<PnPCorrespondence> data;
  std::vector<bool> is_outlier;
};

// Nadir-ish camera 30 m above ground points, noise in pixels, outliers = random observations.
PnPScene MakeScene(int n, double outlier_ratio, double noise_px, uint32_t seed) {
  std::mt19937 rng(seed);
  PnPScene s;
  s.cam_from_world = testing::DownwardCamera({3.0, -2.0, 30.0}, 25.0, 15.0);
  const auto points = testing::PointsInView(s.cam_from_world, n, 20.0, 40.0, 0.8, rng);
  std::normal_distribution<double> gauss(0.0, noise_px / kFocal);
  std::uniform_real_distribution<double> coin(0, 1), u(-0.8, 0.8);
  for (const auto& p : points) {
    const bool outlier = coin(rng) < outlier_ratio;
    Eigen::Vector2d x = testing::Observe(s.cam_from_world, p) + Eigen::Vector2d(gauss(rng), gauss(rng));
    if (outlier) x = Eigen::Vector2d(u(rng), u(rng) * 0.6);
    s.data.push_back({x, p});
    s.is_outlier.push_back(outlier);
  }
  return s;
}

TEST(AbsolutePose, NoiselessSampleIsExact) {
  const PnPScene s = MakeScene(5, 0.0, 0.0, 1);
  const auto models = AbsolutePoseEstimator(kFocal).Fit(s.data);
  ASSERT_FALSE(models.empty());
  EXPECT_LT(RotationErrorDeg(models[0].rotation(), s.cam_from_world.rotation()), 1e-6);
  EXPECT_LT((CameraCenter(models[0]) - CameraCenter(s.cam_from_world)).norm(), 1e-6);
  for (const auto& d : s.data) EXPECT_LT(AbsolutePoseEstimator(kFocal).Residual(models[0], d), 1e-6);
}

TEST(AbsolutePose, RansacRecoversPoseAndFlagsOutliers) {
  const PnPScene s = MakeScene(600, 0.4, 0.5, 2);
  RansacOptions options;
  options.inlier_threshold = 2.0;  // pixels
  const AbsolutePoseEstimator estimator(kFocal);
  const auto result = Ransac(estimator, std::span<const PnPCorrespondence>(s.data), options);
  ASSERT_TRUE(result.success);
  // ~360 inliers with 0.5 px noise at f = 800 at 20-40 m: expected rotation error ~0.002 deg,
  // centre error a few cm.
  EXPECT_LT(RotationErrorDeg(result.model.rotation(), s.cam_from_world.rotation()), 0.02);
  EXPECT_LT((CameraCenter(result.model) - CameraCenter(s.cam_from_world)).norm(), 0.05);
  EXPECT_LT(result.iterations, 1000);
  int missed_inliers = 0, wrong_outliers = 0;
  for (size_t i = 0; i < s.data.size(); ++i) {
    const double true_error = estimator.Residual(s.cam_from_world, s.data[i]);
    if (!s.is_outlier[i]) missed_inliers += result.inlier_mask[i] ? 0 : 1;
    if (true_error > 2.5) wrong_outliers += result.inlier_mask[i] ? 1 : 0;
  }
  EXPECT_LE(missed_inliers, 2);  // 4-sigma noise tails
  EXPECT_EQ(wrong_outliers, 0);
}

TEST(AbsolutePose, PixelsThroughDistortedCamera) {
  Intrinsics intrinsics;
  intrinsics.model = "radial";
  intrinsics.width = 1280;
  intrinsics.height = 720;
  intrinsics.fx = intrinsics.fy = kFocal;
  intrinsics.cx = 639.5;
  intrinsics.cy = 359.5;
  intrinsics.k1 = -0.08;
  intrinsics.k2 = 0.01;
  const Camera camera(intrinsics);
  const PnPScene s = MakeScene(300, 0.0, 0.0, 3);
  std::vector<Eigen::Vector2d> pixels;
  std::vector<Eigen::Vector3d> points;
  for (const auto& d : s.data) {
    Eigen::Vector2d px;
    ASSERT_TRUE(camera.Project(s.cam_from_world * d.point, &px));
    if (!camera.InImage(px)) continue;
    pixels.push_back(px);
    points.push_back(d.point);
  }
  ASSERT_GT(pixels.size(), 100u);
  RansacOptions options;
  options.inlier_threshold = 1.0;
  const auto result = EstimateAbsolutePose(pixels, points, camera, options);
  ASSERT_TRUE(result.success);
  EXPECT_EQ(result.num_inliers, static_cast<int>(pixels.size()));
  EXPECT_LT(RotationErrorDeg(result.model.rotation(), s.cam_from_world.rotation()), 1e-5);
  EXPECT_LT((CameraCenter(result.model) - CameraCenter(s.cam_from_world)).norm(), 1e-5);
}

TEST(AbsolutePose, AllOutliersFail) {
  const PnPScene s = MakeScene(200, 1.0, 0.0, 4);
  RansacOptions options;
  options.inlier_threshold = 2.0;
  options.min_inliers = 30;
  EXPECT_FALSE(Ransac(AbsolutePoseEstimator(kFocal), std::span<const PnPCorrespondence>(s.data), options).success);
}

}  // namespace
}  // namespace glam
