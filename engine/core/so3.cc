#include "engine/core/so3.h"

#include <cmath>

#include <Eigen/SVD>

#include "engine/core/error.h"

namespace glam {
namespace {

// Below this angle the closed forms lose precision (0/0); the Taylor series used instead
// are exact to double precision here (their first dropped term is ~theta^4 or smaller).
constexpr double kSmallAngle = 1e-5;

}  // namespace

Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(),  //
      v.z(), 0, -v.x(),   //
      -v.y(), v.x(), 0;
  return m;
}

SO3::SO3() : q_(Eigen::Quaterniond::Identity()) {}

SO3::SO3(const Eigen::Quaterniond& q) : q_(q) {
  const double n = q_.norm();
  GLAM_CHECK(std::isfinite(n) && n > 1e-12, "SO3 from a zero or non-finite quaternion");
  q_.coeffs() /= n;
}

SO3::SO3(const Eigen::Matrix3d& R) {
  GLAM_CHECK(R.allFinite(), "SO3 from a non-finite matrix");
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d projected = svd.matrixU() * svd.matrixV().transpose();
  GLAM_CHECK(projected.determinant() > 0, "SO3 from a reflection (det < 0)");
  GLAM_CHECK((projected - R).norm() < 1e-4, "SO3 from a matrix that is not a rotation "
             "(distance {} to SO(3))", (projected - R).norm());
  q_ = Eigen::Quaterniond(projected);
  q_.normalize();
}

SO3 SO3::Exp(const Eigen::Vector3d& omega) {
  const double theta2 = omega.squaredNorm();
  const double theta = std::sqrt(theta2);
  double w;
  double k;  // sin(theta/2) / theta
  if (theta < kSmallAngle) {
    w = 1.0 - theta2 / 8.0;
    k = 0.5 - theta2 / 48.0;
  } else {
    w = std::cos(0.5 * theta);
    k = std::sin(0.5 * theta) / theta;
  }
  SO3 r;
  r.q_ = Eigen::Quaterniond(w, k * omega.x(), k * omega.y(), k * omega.z());
  r.q_.normalize();
  return r;
}

Eigen::Vector3d SO3::Log() const {
  // q and -q are the same rotation; pick w >= 0 so the angle lands in [0, pi].
  const double sign = q_.w() < 0 ? -1.0 : 1.0;
  const double w = sign * q_.w();
  const Eigen::Vector3d v = sign * q_.vec();
  const double n = v.norm();  // sin(theta/2)
  double factor;              // theta / sin(theta/2)
  if (n < kSmallAngle) {
    // atan2(n, w) = atan(n/w) = n/w - n^3/(3 w^3) + O(n^5); w ~ 1 here.
    factor = 2.0 / w * (1.0 - n * n / (3.0 * w * w));
  } else {
    // atan2 stays accurate near theta = pi where w -> 0.
    factor = 2.0 * std::atan2(n, w) / n;
  }
  return factor * v;
}

SO3 SO3::Inverse() const {
  SO3 r;
  r.q_ = q_.conjugate();
  return r;
}

SO3 SO3::operator*(const SO3& other) const {
  SO3 r;
  r.q_ = q_ * other.q_;
  r.q_.normalize();  // keep unit length over long chains of products
  return r;
}

Eigen::Vector3d SO3::operator*(const Eigen::Vector3d& p) const { return q_ * p; }

Eigen::Matrix3d SO3::matrix() const { return q_.toRotationMatrix(); }

Eigen::Matrix3d SO3::LeftJacobian(const Eigen::Vector3d& omega) {
  const double theta2 = omega.squaredNorm();
  const double theta = std::sqrt(theta2);
  const Eigen::Matrix3d W = Hat(omega);
  double a;  // (1 - cos theta) / theta^2
  double b;  // (theta - sin theta) / theta^3
  if (theta < kSmallAngle) {
    a = 0.5 - theta2 / 24.0;
    b = 1.0 / 6.0 - theta2 / 120.0;
  } else {
    // 2 sin^2(theta/2), not 1 - cos(theta): the latter cancels and would cost eps/theta in
    // the Hat(omega) term.
    const double half_sin = std::sin(0.5 * theta);
    a = 2.0 * half_sin * half_sin / theta2;
    b = (theta - std::sin(theta)) / (theta2 * theta);
  }
  return Eigen::Matrix3d::Identity() + a * W + b * W * W;
}

Eigen::Matrix3d SO3::LeftJacobianInverse(const Eigen::Vector3d& omega) {
  const double theta2 = omega.squaredNorm();
  const double theta = std::sqrt(theta2);
  const Eigen::Matrix3d W = Hat(omega);
  double c;  // 1/theta^2 - (1 + cos theta) / (2 theta sin theta)
  if (theta < kSmallAngle) {
    c = 1.0 / 12.0 + theta2 / 720.0;
  } else {
    // Rewritten with half angles: (1 - (theta/2) cot(theta/2)) / theta^2; singular only at
    // theta = 2 pi, outside Log's range.
    const double half = 0.5 * theta;
    c = (1.0 - half * std::cos(half) / std::sin(half)) / theta2;
  }
  return Eigen::Matrix3d::Identity() - 0.5 * W + c * W * W;
}

}  // namespace glam
