#include "engine/core/se3.h"

namespace glam {

SE3::SE3() : translation_(Eigen::Vector3d::Zero()) {}

SE3::SE3(const SO3& R, const Eigen::Vector3d& t) : rotation_(R), translation_(t) {}

SE3 SE3::Exp(const Vector6d& xi) {
  const Eigen::Vector3d upsilon = xi.head<3>();
  const Eigen::Vector3d omega = xi.tail<3>();
  return SE3(SO3::Exp(omega), SO3::LeftJacobian(omega) * upsilon);
}

Vector6d SE3::Log() const {
  const Eigen::Vector3d omega = rotation_.Log();
  Vector6d xi;
  xi.head<3>() = SO3::LeftJacobianInverse(omega) * translation_;
  xi.tail<3>() = omega;
  return xi;
}

SE3 SE3::Inverse() const {
  const SO3 r_inv = rotation_.Inverse();
  return SE3(r_inv, -(r_inv * translation_));
}

SE3 SE3::operator*(const SE3& other) const {
  return SE3(rotation_ * other.rotation_, rotation_ * other.translation_ + translation_);
}

Eigen::Vector3d SE3::operator*(const Eigen::Vector3d& p) const {
  return rotation_ * p + translation_;
}

Eigen::Matrix4d SE3::matrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = rotation_.matrix();
  m.topRightCorner<3, 1>() = translation_;
  return m;
}

SE3 SE3::FromMatrix(const Eigen::Matrix4d& m) {
  return SE3(SO3(Eigen::Matrix3d(m.topLeftCorner<3, 3>())), m.topRightCorner<3, 1>());
}

Matrix6d SE3::Adjoint() const {
  const Eigen::Matrix3d R = rotation_.matrix();
  Matrix6d ad = Matrix6d::Zero();
  ad.topLeftCorner<3, 3>() = R;
  ad.topRightCorner<3, 3>() = Hat(translation_) * R;
  ad.bottomRightCorner<3, 3>() = R;
  return ad;
}

}  // namespace glam
