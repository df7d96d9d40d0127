// Sim(3) as a Ceres manifold, for the submap factor graph (paper, "Global Submap Alignment").
//
// Storage (7 doubles, the ambient space): [t (3), omega (3), sigma (1)] where
//   t     = translation,
//   omega = rotation vector of R (SO3::Log, angle in [0, pi]),
//   sigma = log of the scale.
// Why this storage and not [t, q, log s] (8 doubles) or the sim(3) logarithm [upsilon, omega,
// sigma]:
//   * Plus is exact: x (+) delta stores Exp(delta) * X, computed by group composition (no
//     first-order shortcut), so the optimiser takes exactly the paper's step G <- Exp(d) * G.
//   * Its Jacobian is closed form with the SO(3) left Jacobian the project already has:
//       P = d(x (+) delta)/d delta at 0 = [[I, -Hat(t), t], [0, Jl^-1(omega), 0], [0, 0, 1]]
//     (Exp(d) * G moves t to t + upsilon + omega x t + sigma t, R to Exp(omega) R and sigma to
//     sigma + d_sigma). Storing the sim(3) logarithm instead would need the sim(3) left
//     Jacobian, which has no compact closed form.
//   * P is square and invertible (Jl is regular for angles below 2 pi; stored angles are at
//     most pi), so residuals can return their TRUE ambient Jacobian: nothing is faked, and
//     ceres::GradientChecker can compare against numeric ambient derivatives.
//   * The log-scale is a coordinate, so scale stays positive and the scale prior is linear.
// Minus(y, x) = Log(Y * X^-1) (sim(3) logarithm), the exact inverse of Plus; its Jacobian at
// y = x is P^-1 (closed form below).
#pragma once

#include <array>

#include <ceres/manifold.h>
#include <Eigen/Core>

#include "engine/core/sim3.h"

namespace glam {

inline constexpr int kSim3AmbientSize = 7;
inline constexpr int kSim3TangentSize = 7;

using Sim3Parameters = std::array<double, kSim3AmbientSize>;
using Sim3PlusJacobian = Eigen::Matrix<double, 7, 7, Eigen::RowMajor>;

Sim3Parameters Sim3ToParameters(const Sim3& g);
Sim3 Sim3FromParameters(const double* parameters);

// P(x) = D_2 Plus(x, 0) and its inverse (= D_1 Minus(x, x)).
Sim3PlusJacobian Sim3ParametersPlusJacobian(const double* parameters);
Sim3PlusJacobian Sim3ParametersMinusJacobian(const double* parameters);

class Sim3Manifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return kSim3AmbientSize; }
  int TangentSize() const override { return kSim3TangentSize; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

}  // namespace glam
