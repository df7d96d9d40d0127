// Sim3: the closed-form exponential against the matrix exponential of the sim(3) generator
// (catches a decoupled W or a wrong tangent order), exactness for tiny theta and sigma,
// round trips, group axioms, adjoint, and the left-update action Jacobian.
#include "engine/core/sim3.h"

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <unsupported/Eigen/MatrixFunctions>

#include "engine/core/se3.h"

namespace glam {
namespace {

constexpr double kPi = std::numbers::pi;

Eigen::Vector3d RandomUnit(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
}

// Generator [[Hat(omega) + sigma I, upsilon], [0, 0]].
Eigen::Matrix4d Generator(const Vector7d& xi) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m.topLeftCorner<3, 3>() = Hat(xi.segment<3>(3)) + xi(6) * Eigen::Matrix3d::Identity();
  m.topRightCorner<3, 1>() = xi.head<3>();
  return m;
}

const std::vector<double> kAngles = {0.0, 1e-14, 1e-10, 0.999e-6, 1.001e-6, 1e-5,
                                     1e-3, 0.3, 1.5, 3.0, kPi - 1e-6};
const std::vector<double> kSigmas = {0.0, 1e-14, -1e-10, 0.999e-8, 1.001e-8, 1e-6, -1e-3,
                                     0.2, -1.0, 1.999, 2.001, 4.0, -6.0};

std::vector<Vector7d> TestTangents(std::mt19937& rng) {
  std::vector<Vector7d> out;
  for (double angle : kAngles) {
    for (double sigma : kSigmas) {
      for (double length : {1e-9, 2.0}) {
        Vector7d xi;
        xi << length * RandomUnit(rng), angle * RandomUnit(rng), sigma;
        out.push_back(xi);
      }
    }
  }
  return out;
}

Sim3 RandomSim3(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  return Sim3(std::exp(4.0 * u(rng) - 2.0), SO3::Exp(3.0 * u(rng) * RandomUnit(rng)),
              20.0 * u(rng) * RandomUnit(rng));
}

TEST(Sim3Test, ExpMatchesMatrixExponential) {
  std::mt19937 rng(21);
  for (const Vector7d& xi : TestTangents(rng)) {
    const Eigen::Matrix4d expected = Generator(xi).exp();
    const Eigen::Matrix4d actual = Sim3::Exp(xi).matrix();
    EXPECT_LT((actual - expected).norm(), 1e-13 * expected.norm()) << xi.transpose();
  }
}

TEST(Sim3Test, ExpTranslationMatrixMatchesSeries) {
  // W = sum_k A^k / (k+1)!, A = Hat(omega) + sigma I, summed directly: an independent check
  // of the coupled closed form near the Taylor switches, with tight relative tolerance.
  std::mt19937 rng(22);
  for (double angle : {0.0, 1e-12, 0.999e-6, 1.001e-6, 1e-4, 0.05, 0.7}) {
    for (double sigma : {0.0, 1e-13, 0.999e-8, 1.001e-8, 1e-5, -0.01, 0.5, -0.9, 1.5, -1.2}) {
      const Eigen::Vector3d w = angle * RandomUnit(rng);
      const Eigen::Matrix3d A = Hat(w) + sigma * Eigen::Matrix3d::Identity();
      Eigen::Matrix3d series = Eigen::Matrix3d::Zero();
      Eigen::Matrix3d power = Eigen::Matrix3d::Identity();
      double factorial = 1.0;
      for (int k = 0; k < 40; ++k) {
        factorial *= (k + 1);
        series += power / factorial;
        power = power * A;
      }
      const Eigen::Matrix3d W = Sim3::ExpTranslationMatrix(w, sigma);
      EXPECT_LT((W - series).norm(), 1e-15 * series.norm()) << angle << " " << sigma;
      // The rotation-dependent part itself must be relatively exact (not just small).
      const Eigen::Matrix3d skew = 0.5 * (W - W.transpose());
      const Eigen::Matrix3d skew_series = 0.5 * (series - series.transpose());
      EXPECT_LE((skew - skew_series).norm(), 1e-14 * skew_series.norm()) << angle << " "
                                                                         << sigma;
    }
  }
}

TEST(Sim3Test, LogExpRoundTrip) {
  std::mt19937 rng(23);
  for (const Vector7d& xi : TestTangents(rng)) {
    const Vector7d back = Sim3::Exp(xi).Log();
    // Absolute precision: s = exp(sigma) is stored, so sigma is exact to ~eps absolute.
    EXPECT_LT((back - xi).norm(), 2e-14 * (1 + xi.norm())) << xi.transpose();
  }
}

TEST(Sim3Test, LogExpRoundTripNearIdentityIsRelativelyExact) {
  Vector7d tiny;
  tiny << 3e-9, -1e-9, 2e-9, 1e-9, 4e-9, -2e-9, 0.0;
  EXPECT_LT((Sim3::Exp(tiny).Log() - tiny).norm(), 1e-14 * tiny.norm());
  // With a tiny sigma as well: translation and rotation stay relatively exact.
  tiny(6) = 5e-9;
  const Vector7d back = Sim3::Exp(tiny).Log();
  EXPECT_LT((back.head<6>() - tiny.head<6>()).norm(), 1e-14 * tiny.norm());
  EXPECT_NEAR(back(6), tiny(6), 1e-16);
}

TEST(Sim3Test, ExpLogRoundTripOnRandomElements) {
  std::mt19937 rng(24);
  for (int i = 0; i < 100; ++i) {
    const Sim3 G = RandomSim3(rng);
    EXPECT_LT((Sim3::Exp(G.Log()).matrix() - G.matrix()).norm(), 1e-12 * G.matrix().norm());
  }
}

TEST(Sim3Test, UnitScaleAgreesWithSe3) {
  std::mt19937 rng(25);
  for (int i = 0; i < 20; ++i) {
    Vector6d xi6;
    xi6 << 3.0 * RandomUnit(rng), 2.0 * RandomUnit(rng);
    Vector7d xi7;
    xi7 << xi6, 0.0;
    EXPECT_LT((Sim3::Exp(xi7).matrix() - SE3::Exp(xi6).matrix()).norm(), 1e-13);
  }
}

TEST(Sim3Test, GroupAxiomsAndAction) {
  std::mt19937 rng(26);
  const Eigen::Matrix4d I = Eigen::Matrix4d::Identity();
  for (int i = 0; i < 50; ++i) {
    const Sim3 a = RandomSim3(rng), b = RandomSim3(rng), c = RandomSim3(rng);
    const double scale = ((a * b) * c).matrix().norm();
    EXPECT_LT((((a * b) * c).matrix() - (a * (b * c)).matrix()).norm(), 1e-13 * scale);
    EXPECT_LT(((a * a.Inverse()).matrix() - I).norm(), 1e-12);
    EXPECT_LT(((a.Inverse() * a).matrix() - I).norm(), 1e-12);
    EXPECT_LT(((a * Sim3()).matrix() - a.matrix()).norm(), 1e-14 * a.matrix().norm());
    EXPECT_LT(((Sim3() * a).matrix() - a.matrix()).norm(), 1e-14 * a.matrix().norm());
    EXPECT_LT(((a * b).matrix() - a.matrix() * b.matrix()).norm(), 1e-13 * scale);
    EXPECT_LT((a.Inverse().matrix() - a.matrix().inverse()).norm(),
              1e-12 * a.Inverse().matrix().norm());
    EXPECT_NEAR((a * b).scale(), a.scale() * b.scale(), 1e-14 * a.scale() * b.scale());
    const Eigen::Vector3d p(3.0, -1.0, 7.5);
    EXPECT_LT((a * p - (a.matrix() * p.homogeneous()).head<3>()).norm(), 1e-13 * scale);
    EXPECT_LT((a * p - (a.scale() * (a.rotation() * p) + a.translation())).norm(), 1e-13);
    EXPECT_LT(((a * b) * p - a * (b * p)).norm(), 1e-12 * scale);
    const Sim3 back = Sim3::FromMatrix(a.matrix());
    EXPECT_NEAR(back.scale(), a.scale(), 1e-14 * a.scale());
    EXPECT_LT((back.matrix() - a.matrix()).norm(), 1e-13 * a.matrix().norm());
  }
}

TEST(Sim3Test, AdjointConjugatesExp) {
  std::mt19937 rng(27);
  for (int i = 0; i < 30; ++i) {
    const Sim3 G = RandomSim3(rng);
    Vector7d xi;
    xi << RandomUnit(rng), 0.8 * RandomUnit(rng), 0.3;
    const Eigen::Matrix4d lhs = Sim3::Exp(G.Adjoint() * xi).matrix();
    const Eigen::Matrix4d rhs = (G * Sim3::Exp(xi) * G.Inverse()).matrix();
    EXPECT_LT((lhs - rhs).norm(), 1e-11 * rhs.norm());
  }
}

TEST(Sim3Test, ActionLeftJacobianMatchesFiniteDifferences) {
  std::mt19937 rng(28);
  for (int i = 0; i < 20; ++i) {
    const Sim3 G = RandomSim3(rng);
    const Eigen::Vector3d x = 5.0 * RandomUnit(rng);
    const Eigen::Vector3d y = G * x;
    const Eigen::Matrix<double, 3, 7> J = Sim3::ActionLeftJacobian(y);
    Eigen::Matrix<double, 3, 7> numeric;
    const double h = 1e-6;
    for (int k = 0; k < 7; ++k) {
      const Vector7d d = h * Vector7d::Unit(k);
      numeric.col(k) = ((Sim3::Exp(d) * G) * x - (Sim3::Exp(-d) * G) * x) / (2 * h);
    }
    EXPECT_LT((numeric - J).norm(), 1e-7 * (1 + y.norm())) << i;
    // A right update (G * Exp(delta)) has a different Jacobian; make sure we can tell.
    Eigen::Matrix<double, 3, 7> right;
    for (int k = 0; k < 7; ++k) {
      const Vector7d d = h * Vector7d::Unit(k);
      right.col(k) = ((G * Sim3::Exp(d)) * x - (G * Sim3::Exp(-d)) * x) / (2 * h);
    }
    EXPECT_GT((right - J).norm(), 1e-3);
  }
}

}  // namespace
}  // namespace glam
