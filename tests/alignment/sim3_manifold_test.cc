// Sim3Manifold: Plus is the left update Exp(delta) * X, Minus its inverse, and both Jacobians
// agree with numeric differentiation (Ceres' own manifold invariant checks).
#include "engine/alignment/sim3_manifold.h"

#include <random>

#include <ceres/manifold_test_utils.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace glam {
namespace {

using ceres::HasCorrectMinusJacobianAt;
using ceres::HasCorrectPlusJacobianAt;
using ceres::HasCorrectRightMultiplyByPlusJacobianAt;
using ceres::MinusPlusIsIdentityAt;
using ceres::MinusPlusJacobianIsIdentityAt;
using ceres::PlusMinusIsIdentityAt;
using ceres::Vector;
using ceres::XMinusXIsZeroAt;
using ceres::XPlusZeroIsXAt;

Vector7d RandomTangent(std::mt19937& rng, double rotation, double scale_log, double translation) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vector7d xi;
  for (int i = 0; i < 3; ++i) xi(i) = translation * u(rng);
  Eigen::Vector3d axis(u(rng), u(rng), u(rng));
  axis.normalize();
  xi.segment<3>(3) = axis * rotation * std::abs(u(rng));
  xi(6) = scale_log * u(rng);
  return xi;
}

// Random non-trivial Sim3: rotation up to 2.5 rad, scale 0.1 .. 10, translation up to 50.
Sim3 RandomSim3(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Vector3d axis(u(rng), u(rng), u(rng));
  axis.normalize();
  const double angle = 2.5 * std::abs(u(rng));
  const double scale = std::exp(std::log(10.0) * u(rng));
  return Sim3(scale, SO3::Exp(axis * angle), Eigen::Vector3d(50 * u(rng), 50 * u(rng), 50 * u(rng)));
}

Vector ToVector(const Sim3Parameters& p) { return Eigen::Map<const Vector>(p.data(), 7); }

void ExpectSim3Near(const Sim3& a, const Sim3& b, double tol) {
  EXPECT_NEAR(a.scale(), b.scale(), tol * b.scale());
  EXPECT_LT((a.rotation().matrix() - b.rotation().matrix()).norm(), tol);
  EXPECT_LT((a.translation() - b.translation()).norm(), tol * (1 + b.translation().norm()));
}

TEST(Sim3Manifold, ParametersRoundTrip) {
  std::mt19937 rng(1);
  for (int k = 0; k < 20; ++k) {
    const Sim3 g = RandomSim3(rng);
    const Sim3Parameters p = Sim3ToParameters(g);
    ExpectSim3Near(Sim3FromParameters(p.data()), g, 1e-12);
    EXPECT_NEAR(p[6], std::log(g.scale()), 1e-12);
  }
}

TEST(Sim3Manifold, PlusIsLeftMultiplicationByExp) {
  std::mt19937 rng(2);
  const Sim3Manifold manifold;
  for (int k = 0; k < 20; ++k) {
    const Sim3 g = RandomSim3(rng);
    const Vector7d delta = RandomTangent(rng, 0.8, 0.7, 3.0);
    const Sim3Parameters x = Sim3ToParameters(g);
    Sim3Parameters x_plus{};
    ASSERT_TRUE(manifold.Plus(x.data(), delta.data(), x_plus.data()));
    ExpectSim3Near(Sim3FromParameters(x_plus.data()), Sim3::Exp(delta) * g, 1e-11);

    // Minus undoes Plus exactly (not only to first order).
    Vector7d back;
    ASSERT_TRUE(manifold.Minus(x_plus.data(), x.data(), back.data()));
    EXPECT_LT((back - delta).norm(), 1e-10 * (1 + delta.norm())) << k;
  }
}

TEST(Sim3Manifold, InvariantsHoldAtRandomPoints) {
  // Ceres' checks: x + 0 = x, x - x = 0, Minus(Plus) = id, Plus(Minus) = id, Plus/Minus
  // Jacobians against Ridders numeric differentiation, MinusJacobian * PlusJacobian = I.
  std::mt19937 rng(3);
  const Sim3Manifold manifold;
  for (int k = 0; k < 20; ++k) {
    const Vector x = ToVector(Sim3ToParameters(RandomSim3(rng)));
    const Vector y = ToVector(Sim3ToParameters(RandomSim3(rng)));
    const Vector7d d = RandomTangent(rng, 0.5, 0.5, 2.0);
    const Vector delta = d;
    EXPECT_THAT_MANIFOLD_INVARIANTS_HOLD(manifold, x, delta, y, 1e-6);
  }
}

TEST(Sim3Manifold, PlusJacobianHasTheDocumentedBlocks) {
  // Independent check of the closed form: central differences of Plus in each direction.
  std::mt19937 rng(4);
  const Sim3Manifold manifold;
  const Sim3Parameters x = Sim3ToParameters(RandomSim3(rng));
  Sim3PlusJacobian P;
  ASSERT_TRUE(manifold.PlusJacobian(x.data(), P.data()));
  const double h = 1e-6;
  for (int j = 0; j < 7; ++j) {
    Vector7d d = Vector7d::Zero();
    d(j) = h;
    Sim3Parameters plus{}, minus{};
    manifold.Plus(x.data(), d.data(), plus.data());
    d(j) = -h;
    manifold.Plus(x.data(), d.data(), minus.data());
    for (int i = 0; i < 7; ++i) {
      EXPECT_NEAR((plus[i] - minus[i]) / (2 * h), P(i, j), 1e-5 * (1 + std::abs(P(i, j))))
          << i << "," << j;
    }
  }
  Sim3PlusJacobian M;
  ASSERT_TRUE(manifold.MinusJacobian(x.data(), M.data()));
  EXPECT_LT((M * P - Sim3PlusJacobian::Identity()).norm(), 1e-12);
  EXPECT_LT((P * M - Sim3PlusJacobian::Identity()).norm(), 1e-12);
}

}  // namespace
}  // namespace glam
