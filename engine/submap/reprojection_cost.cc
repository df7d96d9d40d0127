#include "engine/submap/reprojection_cost.h"

#include <ceres/product_manifold.h>
#include <Eigen/Geometry>

#include "engine/core/error.h"
#include "engine/core/so3.h"

namespace glam {

ReprojectionCostFunction::ReprojectionCostFunction(const Eigen::Vector2d& observed_pixel,
                                                   const Intrinsics& intrinsics)
    : observed_(observed_pixel), cx_(intrinsics.cx), cy_(intrinsics.cy), k2_(intrinsics.k2), aspect_(intrinsics.fy / intrinsics.fx) {}

bool ReprojectionCostFunction::Evaluate(double const* const* parameters, double* residuals,
                                        double** jacobians) const {
  const double* pose = parameters[0];
  const double focal = parameters[1][0];
  const double k1 = parameters[2][0];
  const Eigen::Map<const Eigen::Vector3d> x(parameters[3]);
  const double w = pose[3];
  const Eigen::Vector3d v(pose[0], pose[1], pose[2]);
  const Eigen::Map<const Eigen::Vector3d> t(pose + 4);

  // Eigen's q * x: x + 2w (v x x) + 2 v x (v x x).
  const Eigen::Vector3d vx = v.cross(x);
  const Eigen::Vector3d p = x + 2.0 * w * vx + 2.0 * v.cross(vx) + t;
  if (p.z() <= Camera::kMinDepth) {
    residuals[0] = residuals[1] = kBehindCameraResidual;
    if (jacobians != nullptr) {
      if (jacobians[0] != nullptr) Eigen::Map<Eigen::Matrix<double, 2, 7>>(jacobians[0]).setZero();
      if (jacobians[1] != nullptr) Eigen::Map<Eigen::Matrix<double, 2, 1>>(jacobians[1]).setZero();
      if (jacobians[2] != nullptr) Eigen::Map<Eigen::Matrix<double, 2, 1>>(jacobians[2]).setZero();
      if (jacobians[3] != nullptr) Eigen::Map<Eigen::Matrix<double, 2, 3>>(jacobians[3]).setZero();
    }
    return true;
  }
  const double inv_z = 1.0 / p.z();
  const double xn = p.x() * inv_z;
  const double yn = p.y() * inv_z;
  const double r2 = xn * xn + yn * yn;
  const double d = 1.0 + k1 * r2 + k2_ * r2 * r2;
  const double fy = focal * aspect_;
  residuals[0] = focal * d * xn + cx_ - observed_.x();
  residuals[1] = fy * d * yn + cy_ - observed_.y();
  if (jacobians == nullptr) return true;

  // d residual / d p (2x3), through the normalised coordinates and the distortion factor.
  Eigen::Matrix<double, 2, 3> dn_dp;  // d (xn, yn) / d p
  dn_dp << inv_z, 0, -xn * inv_z, 0, inv_z, -yn * inv_z;
  const double dd_dr2 = k1 + 2.0 * k2_ * r2;
  const Eigen::RowVector3d dd_dp = dd_dr2 * 2.0 * (xn * dn_dp.row(0) + yn * dn_dp.row(1));
  Eigen::Matrix<double, 2, 3> dr_dp;
  dr_dp.row(0) = focal * (d * dn_dp.row(0) + xn * dd_dp);
  dr_dp.row(1) = fy * (d * dn_dp.row(1) + yn * dd_dp);

  if (jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> j(jacobians[0]);
    // d p / d v = 2w d(v x x)/dv + 2 d(v x (v x x))/dv, with d(v x x)/dv = -[x]x and
    // v x (v x x) = v (v.x) - x (v.v).
    const Eigen::Matrix3d dp_dv = -2.0 * w * Hat(x) +
                                  2.0 * (v.dot(x) * Eigen::Matrix3d::Identity() + v * x.transpose() -
                                         2.0 * x * v.transpose());
    j.block<2, 3>(0, 0) = dr_dp * dp_dv;
    j.col(3) = dr_dp * (2.0 * vx);
    j.block<2, 3>(0, 4) = dr_dp;
  }
  if (jacobians[1] != nullptr) {
    jacobians[1][0] = d * xn;
    jacobians[1][1] = aspect_ * d * yn;
  }
  if (jacobians[2] != nullptr) {
    // d d / d k1 = r^2.
    jacobians[2][0] = focal * r2 * xn;
    jacobians[2][1] = fy * r2 * yn;
  }
  if (jacobians[3] != nullptr) {
    // d p / d x = I + 2w [v]x + 2 [v]x^2.
    const Eigen::Matrix3d sv = Hat(v);
    const Eigen::Matrix3d dp_dx = Eigen::Matrix3d::Identity() + 2.0 * w * sv + 2.0 * sv * sv;
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j(jacobians[3]);
    j = dr_dp * dp_dx;
  }
  return true;
}

ceres::Manifold* NewPoseManifold(int scale_axis) {
  GLAM_CHECK(scale_axis >= -1 && scale_axis < 3);
  if (scale_axis < 0) {
    return new ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>();
  }
  return new ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::SubsetManifold>(
      ceres::EigenQuaternionManifold(), ceres::SubsetManifold(3, {scale_axis}));
}

}  // namespace glam
