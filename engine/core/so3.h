// 3D rotations as a Lie group. Every pose type in GLAM (SE3, Sim3) builds on this one, so
// the conventions live here once:
//   * Tangent vectors are rotation vectors omega (axis * angle, radians).
//   * Updates are LEFT multiplicative, R <- Exp(delta) * R (as in the GLAM paper), so the
//     Jacobians below are left Jacobians.
//   * Exp/Log switch to Taylor expansions near the identity so that tiny increments (the
//     common case inside an optimiser) are exact to machine precision, and Log stays stable
//     near angle pi.
// Storage is a unit quaternion: cheap composition, no drift back towards non-orthogonality.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace glam {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Vector7d = Eigen::Matrix<double, 7, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix7d = Eigen::Matrix<double, 7, 7>;

// Skew-symmetric matrix: Hat(a) * b == a.cross(b).
Eigen::Matrix3d Hat(const Eigen::Vector3d& v);

class SO3 {
 public:
  SO3();  // identity
  // q need not be exactly unit length; it is normalised. Aborts (GLAM_CHECK) on a zero q.
  explicit SO3(const Eigen::Quaterniond& q);
  // R is projected onto the nearest rotation (SVD), so float round-off in R is harmless.
  // Aborts (GLAM_CHECK) if R is not close to a proper rotation (a bug in the caller).
  explicit SO3(const Eigen::Matrix3d& R);

  static SO3 Exp(const Eigen::Vector3d& omega);
  // Rotation vector with angle in [0, pi].
  Eigen::Vector3d Log() const;

  SO3 Inverse() const;
  SO3 operator*(const SO3& other) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const;

  Eigen::Matrix3d matrix() const;
  const Eigen::Quaterniond& quaternion() const { return q_; }

  // J_l(omega) = sum_k Hat(omega)^k / (k+1)!. Exp(omega + d) ~= Exp(J_l(omega) d) * Exp(omega).
  static Eigen::Matrix3d LeftJacobian(const Eigen::Vector3d& omega);
  static Eigen::Matrix3d LeftJacobianInverse(const Eigen::Vector3d& omega);

  // Ad_R = R: R * Exp(w) * R^-1 == Exp(R w).
  Eigen::Matrix3d Adjoint() const { return matrix(); }

 private:
  Eigen::Quaterniond q_;
};

}  // namespace glam
