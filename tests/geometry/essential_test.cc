#include <random>

#include <gtest/gtest.h>

#include "engine/geometry/essential.h"
#include "engine/geometry/triangulation.h"
#include "tests/geometry/synthetic_scene.h"

namespace glam {
namespace {

using testing::AngleBetweenDeg;
using testing::RotationErrorDeg;

constexpr double kFocal = 800.0;

struct TwoViews {
  SE3 cam1_from_world, cam2_from_world;
  SE3 cam2_from_cam1;
  std::vector<TwoViewCorrespondence> data;
  std::vector<bool> is_outlier;
};

TwoViews MakeViews(const Eigen::Vector3d& c2, double yaw2, int n, double outlier_ratio,
                   double noise_px, uint32_t seed) {
  std::mt19937 rng(seed);
  TwoViews v;
  v.cam1_from_world = testing::DownwardCamera({0, 0, 30}, 10.0, 10.0);
  v.cam2_from_world = testing::DownwardCamera(c2, yaw2, 14.0);
  v.cam2_from_cam1 = v.cam2_from_world * v.cam1_from_world.Inverse();
  std::normal_distribution<double> gauss(0.0, noise_px / kFocal);
  std::uniform_real_distribution<double> coin(0, 1), u(-0.7, 0.7);
  for (const auto& p : testing::PointsInView(v.cam1_from_world, n, 20.0, 45.0, 0.7, rng)) {
    if ((v.cam2_from_world * p).z() < 1.0) continue;
    TwoViewCorrespondence c{testing::Observe(v.cam1_from_world, p) + Eigen::Vector2d(gauss(rng), gauss(rng)),
                            testing::Observe(v.cam2_from_world, p) + Eigen::Vector2d(gauss(rng), gauss(rng))};
    const bool outlier = coin(rng) < outlier_ratio;
    if (outlier) c.x2 = Eigen::Vector2d(u(rng), u(rng));
    v.data.push_back(c);
    v.is_outlier.push_back(outlier);
  }
  return v;
}

TEST(Essential, NoiselessMinimalSampleContainsTruth) {
  const TwoViews v = MakeViews({4, 1, 31}, 20.0, 5, 0.0, 0.0, 1);
  ASSERT_EQ(v.data.size(), 5u);
  const auto models = EssentialEstimator(kFocal).Fit(v.data);
  ASSERT_FALSE(models.empty());
  // The true E = [t]x R, up to scale and sign, must be among the solutions.
  const Eigen::Vector3d t = v.cam2_from_cam1.translation().normalized();
  Eigen::Matrix3d truth = Hat(t) * v.cam2_from_cam1.rotation().matrix();
  truth /= truth.norm();
  double best = 1e9;
  for (Eigen::Matrix3d E : models) {
    E /= E.norm();
    best = std::min({best, (E - truth).norm(), (E + truth).norm()});
  }
  EXPECT_LT(best, 1e-6);
}

TEST(Essential, RansacAndCheiralityRecoverRelativePose) {
  const TwoViews v = MakeViews({5, 2, 31}, 25.0, 800, 0.35, 0.5, 2);
  RansacOptions options;
  options.inlier_threshold = 1.5;  // pixels (Sampson)
  const RelativePoseResult r = EstimateRelativePose(v.data, kFocal, options);
  ASSERT_TRUE(r.success);
  EXPECT_LT(RotationErrorDeg(r.cam2_from_cam1.rotation(), v.cam2_from_cam1.rotation()), 0.1);
  EXPECT_NEAR(r.cam2_from_cam1.translation().norm(), 1.0, 1e-9);
  EXPECT_LT(AngleBetweenDeg(r.cam2_from_cam1.translation(), v.cam2_from_cam1.translation()), 1.0);
  int missed = 0, accepted_outliers = 0;
  const EssentialEstimator estimator(kFocal);
  Eigen::Matrix3d true_E = Hat(v.cam2_from_cam1.translation()) * v.cam2_from_cam1.rotation().matrix();
  for (size_t i = 0; i < v.data.size(); ++i) {
    if (!v.is_outlier[i]) missed += r.inlier_mask[i] ? 0 : 1;
    if (estimator.Residual(true_E, v.data[i]) > 3.0) accepted_outliers += r.inlier_mask[i] ? 1 : 0;
  }
  EXPECT_LE(missed, static_cast<int>(v.data.size()) / 100);
  EXPECT_EQ(accepted_outliers, 0);
}

TEST(Essential, ForwardMotionAndSignOfTranslation) {
  // Camera 2 moves along the optical axis of camera 1 (towards the ground) and rotates.
  const TwoViews v = MakeViews({0.5, 0.3, 26}, 15.0, 400, 0.0, 0.3, 3);
  RansacOptions options;
  options.inlier_threshold = 1.0;
  const RelativePoseResult r = EstimateRelativePose(v.data, kFocal, options);
  ASSERT_TRUE(r.success);
  EXPECT_LT(RotationErrorDeg(r.cam2_from_cam1.rotation(), v.cam2_from_cam1.rotation()), 0.2);
  EXPECT_LT(AngleBetweenDeg(r.cam2_from_cam1.translation(), v.cam2_from_cam1.translation()), 2.0);
}

TEST(Essential, RecoverPoseChoosesDecompositionInFront) {
  const TwoViews v = MakeViews({3, -2, 29}, -10.0, 200, 0.0, 0.0, 4);
  Eigen::Matrix3d E = Hat(v.cam2_from_cam1.translation()) * v.cam2_from_cam1.rotation().matrix();
  for (double sign : {1.0, -1.0}) {  // E and -E describe the same geometry
    const RelativePose pose = RecoverRelativePose(sign * E, v.data, std::vector<uint8_t>(v.data.size(), 1));
    EXPECT_EQ(pose.num_inliers, static_cast<int>(v.data.size()));
    EXPECT_LT(RotationErrorDeg(pose.cam2_from_cam1.rotation(), v.cam2_from_cam1.rotation()), 1e-6);
    EXPECT_LT(AngleBetweenDeg(pose.cam2_from_cam1.translation(), v.cam2_from_cam1.translation()), 1e-6);
  }
}

// Nadir views of nearly flat ground (relief +-3 % of the altitude, 60 deg field of view, the
// product's 3 px threshold, parallax 3.4-14 deg as when a bootstrap decides): an essential
// matrix that explains the flow about as well as the true one but puts half the points behind
// the cameras exists here, and scored on Sampson distances alone RANSAC picked it in 5 of
// these 30 pairs (translation 80-95 deg off; 12 of 40 with a 3 m baseline too). The motion
// estimator makes points behind a camera outliers, so the truth wins every time.
TEST(Essential, NadirViewsOfFlatGroundGiveTheTrueMotion) {
  int wrong = 0;
  for (uint32_t seed = 1; seed <= 10; ++seed) {
    for (double baseline : {6.0, 12.0, 24.0}) {
      std::mt19937 rng(seed);
      std::normal_distribution<double> gauss(0.0, 0.5 / kFocal);
      std::uniform_real_distribution<double> ground(-60.0, 60.0), relief(-3.0, 3.0), wobble(-1.0, 1.0);
      const SE3 cam1_from_world = testing::DownwardCamera({0, 0, 100}, 0.0, wobble(rng));
      const SE3 cam2_from_world = testing::DownwardCamera({baseline, 0.0, 100.0 + wobble(rng)}, wobble(rng), wobble(rng));
      std::vector<TwoViewCorrespondence> data;
      while (data.size() < 600) {
        const Eigen::Vector3d p(ground(rng), ground(rng), relief(rng));
        const Eigen::Vector2d x1 = testing::Observe(cam1_from_world, p), x2 = testing::Observe(cam2_from_world, p);
        if (x1.cwiseAbs().maxCoeff() > 0.577 || x2.cwiseAbs().maxCoeff() > 0.577) continue;
        data.push_back({x1 + Eigen::Vector2d(gauss(rng), gauss(rng)), x2 + Eigen::Vector2d(gauss(rng), gauss(rng))});
      }
      RansacOptions options;
      options.inlier_threshold = 3.0;
      options.seed = seed;
      const RelativePoseResult r = EstimateRelativePose(data, kFocal, options, 1e4);
      const SE3 truth = cam2_from_world * cam1_from_world.Inverse();
      const bool right = r.success && r.num_inliers > 0.9 * static_cast<double>(data.size()) &&
                         AngleBetweenDeg(r.cam2_from_cam1.translation(), truth.translation()) < 5.0;
      if (!right) {
        ++wrong;
        ADD_FAILURE() << "seed " << seed << ", baseline " << baseline << " m: " << r.num_inliers << " inliers, translation "
                      << AngleBetweenDeg(r.cam2_from_cam1.translation(), truth.translation()) << " deg off";
      }
    }
  }
  EXPECT_EQ(wrong, 0);
}

// Focal (px) of the oblique views' 640x360 camera (60 degrees horizontal field of view).
constexpr double kObliqueFocal = 554.0;

// Two views 30 deg from nadir at 60 m of the ground z = ground(x, y), 640x360 field of view
// (focal 554 px), 0.5 px noise: camera 2 is 9 m along the view direction (heading 0) or across
// it (90), its yaw changed by yaw_change degrees.
template <typename Ground>
TwoViews ObliqueViews(uint32_t seed, double yaw_change, double heading, const Ground& ground) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0.0, 0.5 / kObliqueFocal);
  std::uniform_real_distribution<double> ux(-0.577, 0.577), uy(-0.325, 0.325);
  TwoViews v;
  v.cam1_from_world = testing::DownwardCamera({0, 0, 60}, 0.0, 30.0);
  const SE3 world_from_cam1 = v.cam1_from_world.Inverse();
  // The camera's horizontal view direction, and the flight direction from it.
  Eigen::Vector3d forward = world_from_cam1.rotation() * Eigen::Vector3d::UnitZ();
  forward.z() = 0;
  forward.normalize();
  const Eigen::Vector3d across = Eigen::Vector3d::UnitZ().cross(forward);
  const double h = testing::Rad(heading);
  const Eigen::Vector3d c2 = Eigen::Vector3d(0, 0, 60) + 9.0 * (std::cos(h) * forward + std::sin(h) * across);
  v.cam2_from_world = testing::DownwardCamera(c2, yaw_change, 30.0);
  v.cam2_from_cam1 = v.cam2_from_world * v.cam1_from_world.Inverse();
  for (int attempt = 0; v.data.size() < 500 && attempt < 20000; ++attempt) {
    const Eigen::Vector3d ray = world_from_cam1.rotation() * Eigen::Vector3d(ux(rng), uy(rng), 1.0);
    const Eigen::Vector3d origin = world_from_cam1.translation();
    if (ray.z() >= -1e-3) continue;
    double s = -origin.z() / ray.z();
    for (int i = 0; i < 20; ++i) s = (ground(origin + s * ray) - origin.z()) / ray.z();  // fixed point
    const Eigen::Vector3d p = origin + s * ray;
    const Eigen::Vector3d in2 = v.cam2_from_world * p;
    if (in2.z() < 1.0) continue;
    const Eigen::Vector2d x2 = in2.head<2>() / in2.z();
    if (std::abs(x2.x()) > 0.577 || std::abs(x2.y()) > 0.325) continue;
    v.data.push_back({testing::Observe(v.cam1_from_world, p) + Eigen::Vector2d(gauss(rng), gauss(rng)),
                      x2 + Eigen::Vector2d(gauss(rng), gauss(rng))});
    v.is_outlier.push_back(false);
  }
  return v;
}

// 12 m of relief.
double RollingGround(const Eigen::Vector3d& p) { return 6.0 * std::sin(p.x() / 25.0) * std::cos(p.y() / 31.0); }

// Camera 2's centre seen from camera 1, unit.
Eigen::Vector3d CentreDirection(const SE3& cam2_from_cam1) { return CameraCenter(cam2_from_cam1).normalized(); }

// Oblique views (30 deg from nadir) of gently rolling ground from 60 m, 640x360 field of view
// (focal 554 px), 0.5 px noise, a turning flight (yaw changes by up to 18 deg between the
// views): the setting in which `glam map` bootstrapped from the wrong of two near-equivalent
// motions (3.1 instead of 9.3 deg parallax on the 600-frame oblique benchmark video). Five-point
// samples of such scenes often fall into the wrong motion's basin; EstimateRelativePose also
// refines the homography's decompositions, which reach the right one.
TEST(Essential, ObliqueViewsOfRollingGroundGiveTheTrueMotion) {
  int wrong = 0, pairs = 0;
  for (uint32_t seed = 1; seed <= 6; ++seed) {
    for (double yaw_change : {0.0, 10.0, 18.0}) {
      for (double heading : {0.0, 90.0}) {  // flying towards the view direction, or across it
        const TwoViews v = ObliqueViews(seed, yaw_change, heading, RollingGround);
        ASSERT_GE(v.data.size(), 300u);
        RansacOptions options;
        options.inlier_threshold = 3.0;
        options.min_inliers = 40;
        options.seed = seed;
        const RelativePoseResult r = EstimateRelativePose(v.data, kObliqueFocal, options, 1e4);
        const SE3& truth = v.cam2_from_cam1;
        const double t_error = AngleBetweenDeg(r.cam2_from_cam1.translation(), truth.translation());
        ++pairs;
        if (!r.success || t_error > 5.0) {
          ++wrong;
          ADD_FAILURE() << "seed " << seed << ", yaw change " << yaw_change << " deg, heading " << heading
                        << " deg: translation " << t_error << " deg off, rotation "
                        << RotationErrorDeg(r.cam2_from_cam1.rotation(), truth.rotation()) << " deg off";
        }
      }
    }
  }
  EXPECT_EQ(pairs, 36);
  EXPECT_EQ(wrong, 0);
}

// Flat ground seen while flying towards the view direction has two motions that explain a
// view pair exactly (the homography's two decompositions put the points in front of both
// cameras): a MotionPreference chooses between them (the bootstrap's twin check builds a
// submap on each). Over rolling ground the other motion explains the views clearly worse, and
// the preference does not take it. (Flying across the view, the second decomposition puts
// the points behind a camera: one motion only.)
TEST(Essential, APreferenceChoosesBetweenTheTwoMotionsOfFlatGround) {
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    for (double heading : {0.0}) {
      SCOPED_TRACE(::testing::Message() << "seed " << seed << ", heading " << heading);
      RansacOptions options;
      options.inlier_threshold = 3.0;
      options.min_inliers = 40;
      options.seed = seed;
      const TwoViews flat = ObliqueViews(seed, 10.0, heading, [](const Eigen::Vector3d&) { return 0.0; });
      const Eigen::Vector3d truth = CentreDirection(flat.cam2_from_cam1);
      const double distinct_cos = std::cos(testing::Rad(kDistinctMotionDeg));
      const RelativePoseResult towards_truth =
          EstimateRelativePose(flat.data, kObliqueFocal, options, 1e4, MotionPreference{truth, 1.1});
      const RelativePoseResult away =
          EstimateRelativePose(flat.data, kObliqueFocal, options, 1e4, MotionPreference{-truth, 1.1});
      const RelativePoseResult free = EstimateRelativePose(flat.data, kObliqueFocal, options, 1e4);
      ASSERT_TRUE(towards_truth.success && away.success && free.success);
      EXPECT_LT(AngleBetweenDeg(CentreDirection(towards_truth.cam2_from_cam1), truth), 3.0);
      const Eigen::Vector3d other = CentreDirection(away.cam2_from_cam1);
      EXPECT_LT(other.dot(truth), distinct_cos) << "no second motion reached";
      // Both explain the views.
      EXPECT_GE(away.num_inliers, 0.95 * towards_truth.num_inliers);
      // Without a preference the result is one of the two.
      const Eigen::Vector3d chosen = CentreDirection(free.cam2_from_cam1);
      EXPECT_TRUE(AngleBetweenDeg(chosen, truth) < 3.0 || AngleBetweenDeg(chosen, other) < 3.0);

      const TwoViews rolling = ObliqueViews(seed, 10.0, heading, RollingGround);
      const RelativePoseResult steered_away =
          EstimateRelativePose(rolling.data, kObliqueFocal, options, 1e4, MotionPreference{-truth, 1.1});
      ASSERT_TRUE(steered_away.success);
      EXPECT_LT(AngleBetweenDeg(CentreDirection(steered_away.cam2_from_cam1), CentreDirection(rolling.cam2_from_cam1)),
                5.0);
    }
  }
}

TEST(Essential, TooFewCorrespondencesFail) {
  const TwoViews v = MakeViews({4, 1, 31}, 20.0, 4, 0.0, 0.0, 5);
  EXPECT_FALSE(EstimateRelativePose(v.data, kFocal, RansacOptions{}).success);
}

}  // namespace
}  // namespace glam
