#include "engine/core/sim3.h"

#include <cmath>

#include <Eigen/LU>

#include "engine/core/error.h"

namespace glam {
namespace {

// Below this rotation angle (and |sigma| >= ~1) the closed form of W divides 0 by 0; the
// Taylor series in theta used instead drops terms of order theta^5 (see ExpTranslationMatrix).
constexpr double kSmallAngle = 1e-6;

// phi1(sigma) = (exp(sigma) - 1) / sigma = integral_0^1 exp(sigma s) ds, exact near 0.
double Phi1(double sigma) {
  if (std::abs(sigma) < 1e-8) return 1.0 + sigma / 2.0 + sigma * sigma / 6.0;
  return std::expm1(sigma) / sigma;
}

// Moment m_k(sigma) = integral_0^1 s^k exp(sigma s) ds.
double Moment(int k, double sigma) {
  if (std::abs(sigma) < 2.0) {
    // Power series sum_j sigma^j / (j! (k + j + 1)); 30 terms leave < 1e-23.
    double term = 1.0;  // sigma^j / j!
    double sum = 0.0;
    for (int j = 0; j < 30; ++j) {
      sum += term / (k + j + 1);
      term *= sigma / (j + 1);
    }
    return sum;
  }
  // Integration by parts: m_k = (e^sigma - k m_{k-1}) / sigma; stable for |sigma| >= 2, k <= 4.
  double m = std::expm1(sigma) / sigma;
  const double e = std::exp(sigma);
  for (int i = 1; i <= k; ++i) m = (e - i * m) / sigma;
  return m;
}

}  // namespace

Sim3::Sim3() : scale_(1.0), translation_(Eigen::Vector3d::Zero()) {}

Sim3::Sim3(double scale, const SO3& R, const Eigen::Vector3d& t)
    : scale_(scale), rotation_(R), translation_(t) {
  GLAM_CHECK(std::isfinite(scale) && scale > 0, "Sim3 scale must be finite and > 0, got {}",
             scale);
}

Eigen::Matrix3d Sim3::ExpTranslationMatrix(const Eigen::Vector3d& omega, double sigma) {
  // With Exp(s Hat(omega)) = I + sin(s theta)/theta Hat + (1 - cos(s theta))/theta^2 Hat^2:
  //   W = C I + A Hat(omega) + B Hat(omega)^2,
  //   C = int e^{sigma s} ds,
  //   A = (1/theta) int e^{sigma s} sin(theta s) ds,
  //   B = (1/theta^2) int e^{sigma s} (1 - cos(theta s)) ds   (all over s in [0, 1]).
  // With z = sigma + i theta and phi1(z) = (e^z - 1)/z = sum_k z^k / (k+1)!:
  //   A = Im phi1(z) / theta,  B = (C - Re phi1(z)) / theta^2.
  const double theta2 = omega.squaredNorm();
  const double theta = std::sqrt(theta2);
  const double C = Phi1(sigma);
  double A;
  double B;
  if (sigma * sigma + theta2 < 1.0) {
    // Near the identity: sum the series with the theta factors divided out exactly.
    // Writing z^k = a_k + i theta b_k and sigma^k - a_k = theta^2 c_k gives the recursions
    // b_{k+1} = a_k + sigma b_k, c_{k+1} = sigma c_k + b_k, a_{k+1} = sigma a_k - theta^2 b_k,
    // with no cancellation for any mix of tiny theta and sigma. |z| < 1, so 25 terms leave
    // < 1e-24.
    double a = 1.0, b = 0.0, c = 0.0;
    double inv_factorial = 1.0;  // 1 / (k+1)!
    A = 0.0;
    B = 0.0;
    for (int k = 1; k <= 25; ++k) {
      const double next_a = sigma * a - theta2 * b;
      const double next_b = a + sigma * b;
      c = sigma * c + b;
      a = next_a;
      b = next_b;
      inv_factorial /= (k + 1);
      A += b * inv_factorial;
      B += c * inv_factorial;
    }
  } else if (theta < kSmallAngle) {
    // |sigma| >= ~1, theta ~ 0: Taylor in theta, sin(theta s)/theta = s - theta^2 s^3/6,
    // (1 - cos(theta s))/theta^2 = s^2/2 - theta^2 s^4/24.
    A = Moment(1, sigma) - theta2 * Moment(3, sigma) / 6.0;
    B = Moment(2, sigma) / 2.0 - theta2 * Moment(4, sigma) / 24.0;
  } else {
    // |z| >= 1: closed form. e^z - 1 = expm1(sigma) cos(theta) - 2 sin^2(theta/2) +
    // i e^sigma sin(theta). B's cancellation costs at most eps * C / theta^2 in B, i.e.
    // eps * C in B * Hat^2, relative precision for W.
    const double half_sin = std::sin(0.5 * theta);
    const double re = std::expm1(sigma) * std::cos(theta) - 2.0 * half_sin * half_sin;
    const double im = std::exp(sigma) * std::sin(theta);
    const double c = sigma * sigma + theta2;
    A = (im * sigma - re * theta) / (theta * c);
    B = (C - (re * sigma + im * theta) / c) / theta2;
  }
  const Eigen::Matrix3d W = Hat(omega);
  return C * Eigen::Matrix3d::Identity() + A * W + B * W * W;
}

Sim3 Sim3::Exp(const Vector7d& xi) {
  const Eigen::Vector3d upsilon = xi.head<3>();
  const Eigen::Vector3d omega = xi.segment<3>(3);
  const double sigma = xi(6);
  return Sim3(std::exp(sigma), SO3::Exp(omega), ExpTranslationMatrix(omega, sigma) * upsilon);
}

Vector7d Sim3::Log() const {
  const Eigen::Vector3d omega = rotation_.Log();
  const double sigma = std::log(scale_);
  // W's eigenvalues are phi1(sigma) and phi1(sigma +- i theta), never 0 for theta <= pi.
  const Eigen::Matrix3d W = ExpTranslationMatrix(omega, sigma);
  Vector7d xi;
  xi.head<3>() = W.partialPivLu().solve(translation_);
  xi.segment<3>(3) = omega;
  xi(6) = sigma;
  return xi;
}

Sim3 Sim3::Inverse() const {
  const SO3 r_inv = rotation_.Inverse();
  return Sim3(1.0 / scale_, r_inv, -(r_inv * translation_) / scale_);
}

Sim3 Sim3::operator*(const Sim3& other) const {
  return Sim3(scale_ * other.scale_, rotation_ * other.rotation_,
              scale_ * (rotation_ * other.translation_) + translation_);
}

Eigen::Vector3d Sim3::operator*(const Eigen::Vector3d& p) const {
  return scale_ * (rotation_ * p) + translation_;
}

Eigen::Matrix4d Sim3::matrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = scale_ * rotation_.matrix();
  m.topRightCorner<3, 1>() = translation_;
  return m;
}

Sim3 Sim3::FromMatrix(const Eigen::Matrix4d& m) {
  const Eigen::Matrix3d sR = m.topLeftCorner<3, 3>();
  const double det = sR.determinant();
  GLAM_CHECK(std::isfinite(det) && det > 0, "Sim3 from a matrix whose 3x3 block has det {}",
             det);
  const double s = std::cbrt(det);
  return Sim3(s, SO3(Eigen::Matrix3d(sR / s)), m.topRightCorner<3, 1>());
}

Matrix7d Sim3::Adjoint() const {
  const Eigen::Matrix3d R = rotation_.matrix();
  Matrix7d ad = Matrix7d::Zero();
  ad.block<3, 3>(0, 0) = scale_ * R;
  ad.block<3, 3>(0, 3) = Hat(translation_) * R;
  ad.block<3, 1>(0, 6) = -translation_;
  ad.block<3, 3>(3, 3) = R;
  ad(6, 6) = 1.0;
  return ad;
}

Eigen::Matrix<double, 3, 7> Sim3::ActionLeftJacobian(const Eigen::Vector3d& y) {
  Eigen::Matrix<double, 3, 7> J;
  J.block<3, 3>(0, 0) = Eigen::Matrix3d::Identity();
  J.block<3, 3>(0, 3) = -Hat(y);
  J.col(6) = y;
  return J;
}

}  // namespace glam
