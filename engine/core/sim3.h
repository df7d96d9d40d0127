// Similarity transforms: submaps have their own origin AND scale (monocular), so the global
// alignment works in Sim(3). Acts as x -> s R x + t.
// Tangent order is [upsilon (3), omega (3), sigma (1)] with s = exp(sigma) (the paper's
// (omega, sigma, mu) reordered; its mu is our sigma). Updates are left multiplicative,
// G <- Exp(delta) * G, as in the paper.
// Exp is the exact closed form of the sim(3) exponential: translation = W(omega, sigma) *
// upsilon, where W = integral_0^1 exp(sigma s) Exp(s omega) ds couples scale and rotation.
// (A decoupled "t = upsilon" or "t = J_l(omega) upsilon" is only first-order correct and
// breaks Log(Exp(x)) == x.) All coefficient functions have Taylor branches so that tiny
// theta and/or sigma are exact to machine precision.
#pragma once

#include <Eigen/Core>

#include "engine/core/so3.h"

namespace glam {

class Sim3 {
 public:
  Sim3();  // identity
  // Aborts (GLAM_CHECK) unless scale > 0 and finite.
  Sim3(double scale, const SO3& R, const Eigen::Vector3d& t);

  static Sim3 Exp(const Vector7d& xi);
  Vector7d Log() const;

  Sim3 Inverse() const;
  Sim3 operator*(const Sim3& other) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const;

  // [[s R, t], [0, 1]].
  Eigen::Matrix4d matrix() const;
  // Scale = cube root of det of the 3x3 block; the rotation is projected onto SO(3).
  // Aborts (GLAM_CHECK) if the 3x3 block has det <= 0.
  static Sim3 FromMatrix(const Eigen::Matrix4d& m);

  // G * Exp(xi) * G^-1 == Exp(Adjoint() * xi);
  // Adjoint = [[s R, Hat(t) R, -t], [0, R, 0], [0, 0, 1]].
  Matrix7d Adjoint() const;

  double scale() const { return scale_; }
  const SO3& rotation() const { return rotation_; }
  const Eigen::Vector3d& translation() const { return translation_; }

  // Jacobian of y = (Exp(delta) * G) * x w.r.t. delta at delta = 0, where y = G * x:
  // [I, -Hat(y), y] (3x7). This is the residual Jacobian of the submap alignment factors.
  static Eigen::Matrix<double, 3, 7> ActionLeftJacobian(const Eigen::Vector3d& y);

  // W(omega, sigma) = sum_k A^k / (k+1)!, A = Hat(omega) + sigma I: Exp's translation is
  // W * upsilon. Exposed for tests and for analytic Jacobians.
  static Eigen::Matrix3d ExpTranslationMatrix(const Eigen::Vector3d& omega, double sigma);

 private:
  double scale_;
  SO3 rotation_;
  Eigen::Vector3d translation_;
};

}  // namespace glam
