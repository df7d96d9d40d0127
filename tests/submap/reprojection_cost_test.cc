// The hand-written Jacobians of ReprojectionCostFunction against automatic differentiation of
// the same projection written independently with Eigen's quaternion, on random poses (also
// non-unit quaternions, as Ceres evaluates between manifold steps), focals, k1, points
// and k2; plus the behind-camera case and the pose manifold's gauge.
#include <random>

#include <ceres/autodiff_cost_function.h>
#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "engine/submap/reprojection_cost.h"

namespace glam {
namespace {

struct ReferenceProjection {
  double u, v, cx, cy, k2, aspect;
  template <typename T>
  bool operator()(const T* pose, const T* focal, const T* k1, const T* point, T* residual) const {
    const Eigen::Quaternion<T> q(pose[3], pose[0], pose[1], pose[2]);
    const Eigen::Matrix<T, 3, 1> p =
        q * Eigen::Matrix<T, 3, 1>(point[0], point[1], point[2]) +
        Eigen::Matrix<T, 3, 1>(pose[4], pose[5], pose[6]);
    const T xn = p.x() / p.z(), yn = p.y() / p.z();
    const T r2 = xn * xn + yn * yn;
    const T d = T(1) + k1[0] * r2 + T(k2) * r2 * r2;
    residual[0] = focal[0] * d * xn + T(cx) - T(u);
    residual[1] = focal[0] * T(aspect) * d * yn + T(cy) - T(v);
    return true;
  }
};

TEST(ReprojectionCost, JacobiansMatchAutomaticDifferentiation) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  Intrinsics in;
  in.width = 640;
  in.height = 360;
  in.fx = 550;
  in.fy = 560;
  in.cx = 321;
  in.cy = 179;
  in.model = "radial";
  in.k2 = 0.01;  // k1 is a parameter, drawn per trial
  int checked = 0;
  for (int trial = 0; trial < 200; ++trial) {
    // Quaternions of norm 0.9-1.1: the formula must hold off the unit sphere as well.
    Eigen::Vector4d q(unit(rng), unit(rng), unit(rng), unit(rng));
    q *= (1.0 + 0.1 * unit(rng)) / q.norm();
    const double pose[7] = {q[0], q[1], q[2], q[3], 3 * unit(rng), 3 * unit(rng), 3 * unit(rng)};
    const double focal = 500 + 100 * unit(rng);
    const double k1 = 0.2 * unit(rng);
    const Eigen::Quaterniond rotation(pose[3], pose[0], pose[1], pose[2]);
    // A point 5-50 m in front of the camera, anywhere in a 60-degree cone.
    const Eigen::Vector3d in_cam(0.5 * unit(rng), 0.3 * unit(rng), 1.0);
    const Eigen::Vector3d point_cam = in_cam * (5 + 45 * (0.5 + 0.5 * unit(rng)));
    const Eigen::Vector3d point = rotation.inverse() * (point_cam - Eigen::Vector3d(pose[4], pose[5], pose[6]));
    const Eigen::Vector2d observed(320 + 200 * unit(rng), 180 + 100 * unit(rng));

    ReprojectionCostFunction analytic(observed, in);
    ceres::AutoDiffCostFunction<ReferenceProjection, 2, 7, 1, 1, 3> reference(
        new ReferenceProjection{observed.x(), observed.y(), in.cx, in.cy, in.k2, in.fy / in.fx});
    const double* parameters[4] = {pose, &focal, &k1, point.data()};
    double r_a[2], r_r[2], ja[4][21], jr[4][21];
    double* jac_a[4] = {ja[0], ja[1], ja[2], ja[3]};
    double* jac_r[4] = {jr[0], jr[1], jr[2], jr[3]};
    ASSERT_TRUE(analytic.Evaluate(parameters, r_a, jac_a));
    ASSERT_TRUE(reference.Evaluate(parameters, r_r, jac_r));
    for (int i = 0; i < 2; ++i) EXPECT_NEAR(r_a[i], r_r[i], 1e-9 * (1 + std::abs(r_r[i])));
    const int sizes[4] = {14, 2, 2, 6};
    for (int b = 0; b < 4; ++b) {
      for (int i = 0; i < sizes[b]; ++i) {
        EXPECT_NEAR(ja[b][i], jr[b][i], 1e-8 * (1 + std::abs(jr[b][i])))
            << "trial " << trial << " block " << b << " entry " << i;
      }
    }
    // Residual only, and a null Jacobian block, are allowed by the Ceres contract.
    double r_only[2];
    ASSERT_TRUE(analytic.Evaluate(parameters, r_only, nullptr));
    EXPECT_EQ(r_only[0], r_a[0]);
    double* only_point[4] = {nullptr, nullptr, nullptr, ja[3]};
    ASSERT_TRUE(analytic.Evaluate(parameters, r_only, only_point));
    ++checked;
  }
  EXPECT_EQ(checked, 200);
}

TEST(ReprojectionCost, PointBehindTheCameraGivesALargeResidualAndNoGradient) {
  Intrinsics in;
  in.width = 640;
  in.height = 360;
  in.fx = in.fy = 500;
  in.cx = 320;
  in.cy = 180;
  const double pose[7] = {0, 0, 0, 1, 0, 0, 0};
  const double focal = 500;
  const double k1 = -0.1;
  const double point[3] = {0.1, 0.2, -3.0};
  const double* parameters[4] = {pose, &focal, &k1, point};
  double r[2], j0[14], j1[2], j2[2], j3[6];
  double* jac[4] = {j0, j1, j2, j3};
  ReprojectionCostFunction cost(Eigen::Vector2d(300, 200), in);
  ASSERT_TRUE(cost.Evaluate(parameters, r, jac));
  EXPECT_EQ(r[0], ReprojectionCostFunction::kBehindCameraResidual);
  EXPECT_EQ(r[1], ReprojectionCostFunction::kBehindCameraResidual);
  for (double v : j0) EXPECT_EQ(v, 0.0);
  for (double v : j2) EXPECT_EQ(v, 0.0);
  for (double v : j3) EXPECT_EQ(v, 0.0);
}

TEST(ReprojectionCost, PoseManifoldHoldsTheScaleAxis) {
  std::unique_ptr<ceres::Manifold> free_pose(NewPoseManifold());
  std::unique_ptr<ceres::Manifold> scale_fixed(NewPoseManifold(2));
  EXPECT_EQ(free_pose->AmbientSize(), 7);
  EXPECT_EQ(free_pose->TangentSize(), 6);
  EXPECT_EQ(scale_fixed->TangentSize(), 5);
  const double x[7] = {0, 0, 0, 1, 1, 2, 3};
  const double delta[5] = {0, 0, 0, 0.5, -0.5};
  double moved[7];
  ASSERT_TRUE(scale_fixed->Plus(x, delta, moved));
  EXPECT_DOUBLE_EQ(moved[4], 1.5);
  EXPECT_DOUBLE_EQ(moved[5], 1.5);
  EXPECT_DOUBLE_EQ(moved[6], 3.0);  // z held
  EXPECT_DOUBLE_EQ(moved[3], 1.0);
}

}  // namespace
}  // namespace glam
