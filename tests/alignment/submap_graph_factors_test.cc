// The graph's factors: analytic Jacobians against numeric ones, both in the ambient storage
// (ceres::GradientChecker, which also maps them through the manifold) and in the tangent
// space (central differences through Plus must give the documented [I, -[y]x, y] / d).
#include "engine/alignment/submap_graph_factors.h"

#include <random>
#include <vector>

#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include "engine/alignment/sim3_manifold.h"

namespace glam {
namespace {

struct Sample {
  Sim3Parameters pose{};
  Eigen::Vector3d landmark;
  Eigen::Vector3d point;
  double depth_scale = 1;
};

// Non-trivial poses: rotations up to 2.5 rad, scales 0.1 .. 10, points up to 20 units, the
// landmark off the mapped point by up to 5 % (residuals are not zero).
Sample RandomSample(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Vector3d axis(u(rng), u(rng), u(rng));
  axis.normalize();
  const Sim3 g(std::exp(std::log(10.0) * u(rng)), SO3::Exp(axis * 2.5 * std::abs(u(rng))),
               Eigen::Vector3d(30 * u(rng), 30 * u(rng), 30 * u(rng)));
  Sample s;
  s.pose = Sim3ToParameters(g);
  s.point = Eigen::Vector3d(20 * u(rng), 20 * u(rng), 20 * u(rng));
  const Eigen::Vector3d y = g * s.point;
  s.landmark = y + 0.05 * y.norm() * Eigen::Vector3d(u(rng), u(rng), u(rng));
  s.depth_scale = 5.0 + 50.0 * std::abs(u(rng));
  return s;
}

TEST(SubmapPointFactor, ResidualIsPointDifferenceOverCurrentDepth) {
  std::mt19937 rng(11);
  const Sample s = RandomSample(rng);
  const SubmapPointFactor factor(s.point, s.depth_scale);
  const double* parameters[2] = {s.pose.data(), s.landmark.data()};
  Eigen::Vector3d r;
  ASSERT_TRUE(factor.Evaluate(parameters, r.data(), nullptr));
  const Sim3 g = Sim3FromParameters(s.pose.data());
  const Eigen::Vector3d expected = (g * s.point - s.landmark) / (g.scale() * s.depth_scale);
  EXPECT_LT((r - expected).norm(), 1e-12 * (1 + expected.norm()));
}

TEST(SubmapPointFactor, GradientCheckerAgreesAtRandomPoses) {
  std::mt19937 rng(12);
  const Sim3Manifold manifold;
  const std::vector<const ceres::Manifold*> manifolds = {&manifold, nullptr};
  for (int k = 0; k < 30; ++k) {
    const Sample s = RandomSample(rng);
    const SubmapPointFactor factor(s.point, s.depth_scale);
    ceres::NumericDiffOptions numeric;
    numeric.relative_step_size = 1e-7;
    const ceres::GradientChecker checker(&factor, &manifolds, numeric);
    const double* parameters[2] = {s.pose.data(), s.landmark.data()};
    ceres::GradientChecker::ProbeResults results;
    // Probe's own verdict is per entry and trips on entries that are 0 analytically and
    // 1e-16 numerically; compare whole blocks instead, ambient and tangent ("local").
    checker.Probe(parameters, 1e-6, &results);
    ASSERT_TRUE(results.return_value);
    for (int block = 0; block < 2; ++block) {
      const ceres::Matrix& a = results.jacobians[block];
      const ceres::Matrix& n = results.numeric_jacobians[block];
      EXPECT_LT((a - n).norm(), 1e-6 * n.norm()) << k << " block " << block << "\n" << a << "\n" << n;
      const ceres::Matrix& la = results.local_jacobians[block];
      const ceres::Matrix& ln = results.local_numeric_jacobians[block];
      EXPECT_LT((la - ln).norm(), 1e-6 * ln.norm()) << k << " block " << block;
    }
  }
}

TEST(SubmapPointFactor, TangentJacobianFollowsFromActionLeftJacobian) {
  std::mt19937 rng(13);
  const Sim3Manifold manifold;
  for (int k = 0; k < 30; ++k) {
    const Sample s = RandomSample(rng);
    const SubmapPointFactor factor(s.point, s.depth_scale);
    const double* parameters[2] = {s.pose.data(), s.landmark.data()};
    Eigen::Vector3d r;
    Eigen::Matrix<double, 3, 7, Eigen::RowMajor> J_pose;
    Eigen::Matrix<double, 3, 3, Eigen::RowMajor> J_landmark;
    double* jacobians[2] = {J_pose.data(), J_landmark.data()};
    ASSERT_TRUE(factor.Evaluate(parameters, r.data(), jacobians));

    // What Ceres uses: ambient Jacobian times PlusJacobian.
    Sim3PlusJacobian P;
    manifold.PlusJacobian(s.pose.data(), P.data());
    const Eigen::Matrix<double, 3, 7> J_tangent = J_pose * P;
    // Quotient rule on (y - X) / (s d) with the convention's d(y)/d(delta) = [I, -Hat(y), y]
    // and d(s)/d(delta) = s e_sigma^T: [I, -Hat(y), y - (y - X)] / (s d) = [I, -Hat(y), X] / (s d).
    const Sim3 g = Sim3FromParameters(s.pose.data());
    const Eigen::Vector3d y = g * s.point;
    const double sd = g.scale() * s.depth_scale;
    Eigen::Matrix<double, 3, 7> expected = Sim3::ActionLeftJacobian(y) / sd;
    expected.col(6) -= (y - s.landmark) / sd;
    EXPECT_LT((J_tangent - expected).norm(), 1e-10 * (1 + expected.norm())) << k;
    EXPECT_LT((J_landmark + Eigen::Matrix3d::Identity() / sd).norm(), 1e-15 / sd);

    // And numerically: central differences of r(x (+) delta) in each tangent direction.
    const double h = 1e-6;
    for (int j = 0; j < 7; ++j) {
      Vector7d d = Vector7d::Zero();
      Sim3Parameters plus{}, minus{};
      d(j) = h;
      manifold.Plus(s.pose.data(), d.data(), plus.data());
      d(j) = -h;
      manifold.Plus(s.pose.data(), d.data(), minus.data());
      Eigen::Vector3d r_plus, r_minus;
      const double* p_plus[2] = {plus.data(), s.landmark.data()};
      const double* p_minus[2] = {minus.data(), s.landmark.data()};
      factor.Evaluate(p_plus, r_plus.data(), nullptr);
      factor.Evaluate(p_minus, r_minus.data(), nullptr);
      const Eigen::Vector3d numeric = (r_plus - r_minus) / (2 * h);
      EXPECT_LT((numeric - expected.col(j)).norm(), 1e-6 * (1 + expected.col(j).norm()))
          << k << " column " << j;
    }
  }
}

TEST(LogScalePriorFactor, PenalisesChangeOfLogScaleOnly) {
  const Sim3 g(2.5, SO3::Exp(Eigen::Vector3d(0.3, -0.2, 0.1)), Eigen::Vector3d(1, 2, 3));
  const Sim3Parameters p = Sim3ToParameters(g);
  const double weight = 3.0;
  const LogScalePriorFactor at_insertion(std::log(2.5), weight);
  const double* parameters[1] = {p.data()};
  double r = 1;
  ASSERT_TRUE(at_insertion.Evaluate(parameters, &r, nullptr));
  EXPECT_NEAR(r, 0.0, 1e-15);

  const LogScalePriorFactor factor(std::log(2.0), weight);
  const Sim3Manifold manifold;
  const std::vector<const ceres::Manifold*> manifolds = {&manifold};
  const ceres::GradientChecker checker(&factor, &manifolds, ceres::NumericDiffOptions());
  ceres::GradientChecker::ProbeResults results;
  checker.Probe(parameters, 1e-8, &results);
  ASSERT_TRUE(results.return_value);
  EXPECT_LT((results.jacobians[0] - results.numeric_jacobians[0]).norm(), 1e-8 * weight);
  EXPECT_NEAR(results.residuals(0), weight * std::log(2.5 / 2.0), 1e-12);
  // Only the log-scale direction of the tangent moves it.
  Eigen::Matrix<double, 1, 7> expected = Eigen::Matrix<double, 1, 7>::Zero();
  expected(6) = weight;
  EXPECT_LT((results.local_jacobians[0] - expected).norm(), 1e-12);
}

}  // namespace
}  // namespace glam
