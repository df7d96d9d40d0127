// SE3: exp/log against the matrix exponential of the twist (checks the [upsilon, omega]
// tangent order), round trips, group axioms, adjoint, and the left-update Jacobian.
#include "engine/core/se3.h"

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <unsupported/Eigen/MatrixFunctions>

namespace glam {
namespace {

constexpr double kPi = std::numbers::pi;

Eigen::Vector3d RandomUnit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
}

// Twists with rotation angles in the delicate regimes and translations of mixed size.
std::vector<Vector6d> TestTwists(std::mt19937& rng) {
  std::vector<Vector6d> out;
  for (double angle : {0.0, 1e-14, 1e-9, 9.99e-6, 1.001e-5, 1e-3, 0.5, 2.0, 3.0, kPi - 1e-6}) {
    for (double length : {0.0, 1e-9, 1.0, 50.0}) {
      Vector6d xi;
      xi << length * RandomUnit(rng), angle * RandomUnit(rng);
      out.push_back(xi);
    }
  }
  return out;
}

Eigen::Matrix4d TwistMatrix(const Vector6d& xi) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m.topLeftCorner<3, 3>() = Hat(xi.tail<3>());
  m.topRightCorner<3, 1>() = xi.head<3>();
  return m;
}

SE3 RandomPose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 3.0);
  return SE3(SO3::Exp(u(rng) * RandomUnit(rng)), 10.0 * u(rng) * RandomUnit(rng));
}

TEST(Se3Test, ExpMatchesMatrixExponential) {
  std::mt19937 rng(11);
  for (const Vector6d& xi : TestTwists(rng)) {
    const Eigen::Matrix4d expected = TwistMatrix(xi).exp();
    EXPECT_LT((SE3::Exp(xi).matrix() - expected).norm(), 1e-12 * (1 + expected.norm()))
        << xi.transpose();
  }
}

TEST(Se3Test, LogExpRoundTrip) {
  std::mt19937 rng(12);
  for (const Vector6d& xi : TestTwists(rng)) {
    const Vector6d back = SE3::Exp(xi).Log();
    EXPECT_LT((back - xi).norm(), 1e-13 * (1 + xi.norm())) << xi.transpose();
  }
  // Near the identity the round trip keeps relative precision.
  Vector6d tiny;
  tiny << 3e-10, -1e-10, 2e-10, 1e-10, 4e-10, -2e-10;
  EXPECT_LT((SE3::Exp(tiny).Log() - tiny).norm(), 1e-14 * tiny.norm());
}

TEST(Se3Test, ExpLogRoundTripOnRandomPoses) {
  std::mt19937 rng(13);
  for (int i = 0; i < 100; ++i) {
    const SE3 T = RandomPose(rng);
    EXPECT_LT((SE3::Exp(T.Log()).matrix() - T.matrix()).norm(), 1e-12);
  }
}

TEST(Se3Test, GroupAxiomsAndAction) {
  std::mt19937 rng(14);
  const Eigen::Matrix4d I = Eigen::Matrix4d::Identity();
  for (int i = 0; i < 50; ++i) {
    const SE3 a = RandomPose(rng), b = RandomPose(rng), c = RandomPose(rng);
    EXPECT_LT((((a * b) * c).matrix() - (a * (b * c)).matrix()).norm(), 1e-12);
    EXPECT_LT(((a * a.Inverse()).matrix() - I).norm(), 1e-13);
    EXPECT_LT(((a.Inverse() * a).matrix() - I).norm(), 1e-13);
    EXPECT_LT(((a * SE3()).matrix() - a.matrix()).norm(), 1e-14);
    EXPECT_LT(((SE3() * a).matrix() - a.matrix()).norm(), 1e-14);
    EXPECT_LT(((a * b).matrix() - a.matrix() * b.matrix()).norm(), 1e-12);
    EXPECT_LT((a.Inverse().matrix() - a.matrix().inverse()).norm(), 1e-12);
    const Eigen::Vector3d p(3.0, -1.0, 7.5);
    EXPECT_LT((a * p - (a.matrix() * p.homogeneous()).head<3>()).norm(), 1e-13);
    // c_from_a = c_from_b * b_from_a acts like applying b_from_a first.
    EXPECT_LT(((a * b) * p - a * (b * p)).norm(), 1e-12);
    EXPECT_LT((SE3::FromMatrix(a.matrix()).matrix() - a.matrix()).norm(), 1e-14);
  }
}

TEST(Se3Test, AccessorsAndConstruction) {
  const SO3 R = SO3::Exp(Eigen::Vector3d(0.1, 0.2, 0.3));
  const Eigen::Vector3d t(1, 2, 3);
  SE3 T(R, t);
  EXPECT_EQ(T.translation(), t);
  EXPECT_LT((T.rotation().matrix() - R.matrix()).norm(), 1e-15);
  EXPECT_LT((T * Eigen::Vector3d::Zero() - t).norm(), 1e-15);
  T.translation() = Eigen::Vector3d(-1, 0, 0);
  T.rotation() = SO3();
  EXPECT_LT((T * Eigen::Vector3d(1, 1, 1) - Eigen::Vector3d(0, 1, 1)).norm(), 1e-15);
}

TEST(Se3Test, AdjointConjugatesExp) {
  std::mt19937 rng(15);
  for (int i = 0; i < 30; ++i) {
    const SE3 T = RandomPose(rng);
    Vector6d xi;
    xi << RandomUnit(rng), 0.8 * RandomUnit(rng);
    const Eigen::Matrix4d lhs = SE3::Exp(T.Adjoint() * xi).matrix();
    const Eigen::Matrix4d rhs = (T * SE3::Exp(xi) * T.Inverse()).matrix();
    EXPECT_LT((lhs - rhs).norm(), 1e-11);
  }
}

TEST(Se3Test, LeftUpdateJacobianOfAction) {
  // d/d delta of (Exp(delta) * T) * x at 0 is [I, -Hat(y)], y = T * x: this pins both the
  // tangent order and the left-multiplicative update.
  std::mt19937 rng(16);
  for (int i = 0; i < 10; ++i) {
    const SE3 T = RandomPose(rng);
    const Eigen::Vector3d x = 5.0 * RandomUnit(rng);
    const Eigen::Vector3d y = T * x;
    Eigen::Matrix<double, 3, 6> expected;
    expected << Eigen::Matrix3d::Identity(), -Hat(y);
    Eigen::Matrix<double, 3, 6> numeric;
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      const Vector6d d = h * Vector6d::Unit(k);
      numeric.col(k) = ((SE3::Exp(d) * T) * x - (SE3::Exp(-d) * T) * x) / (2 * h);
    }
    EXPECT_LT((numeric - expected).norm(), 1e-7);
  }
}

}  // namespace
}  // namespace glam
