#include "engine/alignment/submap_graph_factors.h"

#include <cmath>

#include "engine/core/error.h"
#include "engine/core/so3.h"

namespace glam {

SubmapPointFactor::SubmapPointFactor(const Eigen::Vector3d& point_in_submap,
                                     double depth_in_submap_units)
    : point_in_submap_(point_in_submap), inverse_depth_(1.0 / depth_in_submap_units) {
  GLAM_CHECK(std::isfinite(depth_in_submap_units) && depth_in_submap_units > 0,
             "depth scale must be > 0, got {}", depth_in_submap_units);
}

bool SubmapPointFactor::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  // r = (s R x + t - X) / (s d) = (R x + (t - X) / s) / d.
  const Eigen::Map<const Eigen::Vector3d> t(parameters[0]);
  const Eigen::Map<const Eigen::Vector3d> omega(parameters[0] + 3);
  const double inverse_scale = std::exp(-parameters[0][6]);
  const Eigen::Map<const Eigen::Vector3d> X(parameters[1]);

  const Eigen::Vector3d rx = SO3::Exp(omega) * point_in_submap_;
  const Eigen::Vector3d t_minus_X = t - X;
  Eigen::Map<Eigen::Vector3d> r(residuals);
  r = (rx + t_minus_X * inverse_scale) * inverse_depth_;
  if (jacobians == nullptr) return true;

  const double w = inverse_scale * inverse_depth_;
  if (jacobians[0] != nullptr) {
    // d/dt = I / (s d), d/domega = -Hat(R x) Jl(omega) / d, d/dsigma = -(t - X) / (s d).
    Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> J(jacobians[0]);
    J.block<3, 3>(0, 0) = Eigen::Matrix3d::Identity() * w;
    J.block<3, 3>(0, 3) = -Hat(rx) * SO3::LeftJacobian(omega) * inverse_depth_;
    J.col(6) = -t_minus_X * w;
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[1]);
    J = -Eigen::Matrix3d::Identity() * w;
  }
  return true;
}

LogScalePriorFactor::LogScalePriorFactor(double initial_log_scale, double weight)
    : initial_log_scale_(initial_log_scale), weight_(weight) {}

bool LogScalePriorFactor::Evaluate(double const* const* parameters, double* residuals,
                                   double** jacobians) const {
  residuals[0] = weight_ * (parameters[0][6] - initial_log_scale_);
  if (jacobians != nullptr && jacobians[0] != nullptr) {
    // sigma is a storage coordinate and P's last row is [0 ... 0 1]: tangent Jacobian
    // [0 ... 0 lambda] as well.
    for (int i = 0; i < 6; ++i) jacobians[0][i] = 0.0;
    jacobians[0][6] = weight_;
  }
  return true;
}

}  // namespace glam
