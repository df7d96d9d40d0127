// SO3: exp/log exactness (tiny and near-pi angles), agreement with Eigen's AngleAxis,
// group axioms, and the LEFT Jacobian convention.
#include "engine/core/so3.h"

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace glam {
namespace {

constexpr double kPi = std::numbers::pi;

Eigen::Vector3d RandomAxis(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
}

// Rotation vectors covering the numerically delicate regimes.
std::vector<Eigen::Vector3d> TestRotationVectors(std::mt19937& rng) {
  const std::vector<double> angles = {0.0,  1e-15, 1e-12, 1e-9,     3e-6,      9.99e-6, 1.001e-5,
                                      1e-4, 1e-2,  0.5,   1.0,      2.0,       3.0,     kPi - 1e-4,
                                      kPi - 1e-7, kPi - 1e-9};
  std::vector<Eigen::Vector3d> out;
  for (double a : angles) {
    for (int i = 0; i < 5; ++i) out.push_back(a * RandomAxis(rng));
  }
  std::uniform_real_distribution<double> u(0.0, kPi - 1e-3);
  for (int i = 0; i < 100; ++i) out.push_back(u(rng) * RandomAxis(rng));
  return out;
}

SO3 RandomRotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return SO3(Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)));
}

TEST(So3Test, HatIsCrossProduct) {
  const Eigen::Vector3d a(0.3, -1.2, 2.0);
  const Eigen::Vector3d b(-0.7, 0.4, 1.5);
  EXPECT_LT((Hat(a) * b - a.cross(b)).norm(), 1e-15);
  EXPECT_LT((Hat(a) + Hat(a).transpose()).norm(), 1e-15);
}

TEST(So3Test, ExpMatchesAngleAxis) {
  std::mt19937 rng(1);
  for (const Eigen::Vector3d& w : TestRotationVectors(rng)) {
    const double theta = w.norm();
    const Eigen::Matrix3d expected =
        theta > 0 ? Eigen::AngleAxisd(theta, w / theta).toRotationMatrix()
                  : Eigen::Matrix3d::Identity();
    EXPECT_LT((SO3::Exp(w).matrix() - expected).norm(), 1e-14) << w.transpose();
  }
}

TEST(So3Test, ExpOfTinyAngleIsExactToFirstOrder) {
  // Near identity Exp(w) = I + Hat(w) + O(theta^2): the off-diagonal part must carry w with
  // full relative precision (a 0/0-prone formula would lose it).
  for (double theta : {1e-15, 1e-12, 1e-9, 1e-7}) {
    const Eigen::Vector3d w = theta * Eigen::Vector3d(0.6, -0.8, 0.0);
    const Eigen::Matrix3d R = SO3::Exp(w).matrix();
    const Eigen::Matrix3d skew = 0.5 * (R - R.transpose());
    EXPECT_LT((skew - Hat(w)).norm(), 1e-14 * theta) << theta;
  }
}

TEST(So3Test, LogExpRoundTrip) {
  std::mt19937 rng(2);
  for (const Eigen::Vector3d& w : TestRotationVectors(rng)) {
    const Eigen::Vector3d back = SO3::Exp(w).Log();
    // Relative precision near identity, absolute precision elsewhere.
    EXPECT_LT((back - w).norm(), 1e-14 * std::max(w.norm(), 1e-300) + 1e-14) << w.transpose();
    if (w.norm() > 0 && w.norm() < 1e-4) {
      EXPECT_LT((back - w).norm() / w.norm(), 1e-14) << w.transpose();
    }
  }
}

TEST(So3Test, ExpLogRoundTripOnRandomRotations) {
  std::mt19937 rng(3);
  for (int i = 0; i < 200; ++i) {
    const SO3 R = RandomRotation(rng);
    const Eigen::Vector3d w = R.Log();
    EXPECT_LE(w.norm(), kPi + 1e-12);
    EXPECT_LT((SO3::Exp(w).matrix() - R.matrix()).norm(), 1e-14);
  }
}

TEST(So3Test, LogWrapsAnglesAbovePi) {
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, -2).normalized();
  const Eigen::Vector3d w = SO3::Exp(1.5 * kPi * axis).Log();
  EXPECT_LT((w - (-0.5 * kPi) * axis).norm(), 1e-14);
}

TEST(So3Test, GroupAxioms) {
  std::mt19937 rng(4);
  for (int i = 0; i < 50; ++i) {
    const SO3 a = RandomRotation(rng), b = RandomRotation(rng), c = RandomRotation(rng);
    EXPECT_LT((((a * b) * c).matrix() - (a * (b * c)).matrix()).norm(), 1e-14);
    EXPECT_LT(((a * a.Inverse()).matrix() - Eigen::Matrix3d::Identity()).norm(), 1e-14);
    EXPECT_LT(((a.Inverse() * a).matrix() - Eigen::Matrix3d::Identity()).norm(), 1e-14);
    EXPECT_LT(((a * SO3()).matrix() - a.matrix()).norm(), 1e-14);
    EXPECT_LT(((SO3() * a).matrix() - a.matrix()).norm(), 1e-14);
    EXPECT_LT(((a * b).matrix() - a.matrix() * b.matrix()).norm(), 1e-14);
    const Eigen::Vector3d p(1.5, -2.0, 0.25);
    EXPECT_LT((a * p - a.matrix() * p).norm(), 1e-14);
    EXPECT_LT(((a * b) * p - a * (b * p)).norm(), 1e-14);
    EXPECT_NEAR(a.matrix().determinant(), 1.0, 1e-14);
  }
}

TEST(So3Test, ConstructFromMatrixAndQuaternion) {
  std::mt19937 rng(5);
  for (int i = 0; i < 20; ++i) {
    const SO3 a = RandomRotation(rng);
    EXPECT_LT((SO3(a.matrix()).matrix() - a.matrix()).norm(), 1e-14);
    // Float round-off in the input is projected away.
    const Eigen::Matrix3d noisy = a.matrix().cast<float>().cast<double>();
    const Eigen::Matrix3d projected = SO3(noisy).matrix();
    EXPECT_LT((projected.transpose() * projected - Eigen::Matrix3d::Identity()).norm(), 1e-14);
    EXPECT_LT((projected - a.matrix()).norm(), 1e-6);
    // Non-unit quaternions are normalised.
    Eigen::Quaterniond scaled = a.quaternion();
    scaled.coeffs() *= 3.0;
    EXPECT_LT((SO3(scaled).matrix() - a.matrix()).norm(), 1e-14);
  }
}

TEST(So3Test, AdjointConjugatesExp) {
  std::mt19937 rng(6);
  for (int i = 0; i < 20; ++i) {
    const SO3 R = RandomRotation(rng);
    const Eigen::Vector3d w = 0.7 * RandomAxis(rng);
    const Eigen::Matrix3d lhs = SO3::Exp(R.Adjoint() * w).matrix();
    const Eigen::Matrix3d rhs = (R * SO3::Exp(w) * R.Inverse()).matrix();
    EXPECT_LT((lhs - rhs).norm(), 1e-14);
  }
}

// Column i of the LEFT Jacobian: d/dh Log(Exp(w + h e_i) * Exp(w)^-1) at h = 0.
Eigen::Matrix3d NumericLeftJacobian(const Eigen::Vector3d& w) {
  const double h = 1e-6;
  Eigen::Matrix3d J;
  const SO3 inv = SO3::Exp(w).Inverse();
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d e = h * Eigen::Vector3d::Unit(i);
    J.col(i) = ((SO3::Exp(w + e) * inv).Log() - (SO3::Exp(w - e) * inv).Log()) / (2 * h);
  }
  return J;
}

TEST(So3Test, LeftJacobianMatchesNumeric) {
  std::mt19937 rng(7);
  for (double theta : {0.0, 1e-9, 1e-5, 0.1, 1.0, 2.5, 3.0}) {
    const Eigen::Vector3d w = theta * RandomAxis(rng);
    const Eigen::Matrix3d J = SO3::LeftJacobian(w);
    EXPECT_LT((J - NumericLeftJacobian(w)).norm(), 1e-8) << theta;
    if (theta > 0.1) {
      // The right Jacobian (J^T) would be wrong here: make sure the test can tell.
      EXPECT_GT((J.transpose() - NumericLeftJacobian(w)).norm(), 1e-3);
    }
  }
}

TEST(So3Test, LeftJacobianInverseIsInverse) {
  std::mt19937 rng(8);
  for (double theta : {0.0, 1e-12, 1e-6, 9.9e-6, 1.1e-5, 1e-3, 0.5, 2.0, 3.0, kPi - 1e-6}) {
    const Eigen::Vector3d w = theta * RandomAxis(rng);
    const Eigen::Matrix3d product = SO3::LeftJacobianInverse(w) * SO3::LeftJacobian(w);
    EXPECT_LT((product - Eigen::Matrix3d::Identity()).norm(), 1e-13) << theta;
  }
}

TEST(So3Test, LeftJacobianMatchesSeriesOnBothSidesOfTaylorSwitch) {
  // J_l = sum_k Hat(w)^k / (k+1)!, summed directly (converges fast for theta < 1).
  const Eigen::Vector3d axis = Eigen::Vector3d(0.2, 0.3, -0.9).normalized();
  for (double theta : {1e-7, 0.999e-5, 1.001e-5, 1e-3, 0.3}) {
    const Eigen::Matrix3d W = Hat(theta * axis);
    Eigen::Matrix3d series = Eigen::Matrix3d::Zero();
    Eigen::Matrix3d power = Eigen::Matrix3d::Identity();
    double factorial = 1.0;
    for (int k = 0; k < 25; ++k) {
      factorial *= (k + 1);
      series += power / factorial;
      power = power * W;
    }
    EXPECT_LT((SO3::LeftJacobian(theta * axis) - series).norm(), 1e-15) << theta;
  }
}

}  // namespace
}  // namespace glam
