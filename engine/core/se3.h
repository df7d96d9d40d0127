// Rigid transforms (camera poses inside a submap). Acts as x -> R x + t.
// Tangent order is [upsilon (translation part, 3), omega (rotation, 3)], the same prefix as
// Sim3's tangent so code that handles both lines up. Updates are left multiplicative:
// T <- Exp(delta) * T. Name variables by frames: cam_from_world * point_in_world.
#pragma once

#include <Eigen/Core>

#include "engine/core/so3.h"

namespace glam {

class SE3 {
 public:
  SE3();  // identity
  SE3(const SO3& R, const Eigen::Vector3d& t);

  // Exp([upsilon, omega]) = (Exp(omega), J_l(omega) * upsilon).
  static SE3 Exp(const Vector6d& xi);
  Vector6d Log() const;

  SE3 Inverse() const;
  SE3 operator*(const SE3& other) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const;

  Eigen::Matrix4d matrix() const;
  // The rotation block is projected onto SO(3) (see SO3(const Matrix3d&)).
  static SE3 FromMatrix(const Eigen::Matrix4d& m);

  // T * Exp(xi) * T^-1 == Exp(Adjoint() * xi); Adjoint = [[R, Hat(t) R], [0, R]].
  Matrix6d Adjoint() const;

  const SO3& rotation() const { return rotation_; }
  const Eigen::Vector3d& translation() const { return translation_; }
  SO3& rotation() { return rotation_; }
  Eigen::Vector3d& translation() { return translation_; }

 private:
  SO3 rotation_;
  Eigen::Vector3d translation_;
};

}  // namespace glam
