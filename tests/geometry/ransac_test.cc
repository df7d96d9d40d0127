#include <random>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "engine/core/error.h"
#include "engine/geometry/ransac.h"

namespace glam {
namespace {

// Trivial estimator for testing the loop: 2D line n.p + c = 0 with |n| = 1.
struct LineEstimator {
  using Datum = Eigen::Vector2d;
  using Model = Eigen::Vector3d;
  static constexpr int kMinSampleSize = 2;

  std::vector<Model> Fit(std::span<const Datum> s) const {
    const Eigen::Vector2d d = s[1] - s[0];
    if (d.norm() < 1e-12) return {};  // degenerate sample
    const Eigen::Vector2d n = Eigen::Vector2d(-d.y(), d.x()).normalized();
    return {Model(n.x(), n.y(), -n.dot(s[0]))};
  }
  double Residual(const Model& m, const Datum& p) const {
    return std::abs(m.head<2>().dot(p) + m.z());
  }
};

// Adds total-least-squares refinement on the inliers.
struct RefinableLineEstimator : LineEstimator {
  bool Refine(std::span<const Datum> inliers, Model* m) const {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const auto& p : inliers) mean += p;
    mean /= static_cast<double>(inliers.size());
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (const auto& p : inliers) cov += (p - mean) * (p - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
    const Eigen::Vector2d n = eig.eigenvectors().col(0);
    *m = Model(n.x(), n.y(), -n.dot(mean));
    ++refine_calls;
    return true;
  }
  mutable int refine_calls = 0;
};

static_assert(RansacEstimator<LineEstimator>);
static_assert(!RefinableEstimator<LineEstimator>);
static_assert(RefinableEstimator<RefinableLineEstimator>);

// y = 0.5 x + 1 as n.p + c = 0.
const Eigen::Vector3d kTrueLine = Eigen::Vector3d(0.5, -1.0, 1.0) / std::sqrt(1.25);

struct LineData {
  std::vector<Eigen::Vector2d> points;
  std::vector<bool> is_outlier;
};

LineData MakeLine(int n, double outlier_ratio, double noise, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-10, 10), box(-10, 10), coin(0, 1);
  std::normal_distribution<double> gauss(0, noise);
  LineData data;
  for (int i = 0; i < n; ++i) {
    const bool outlier = coin(rng) < outlier_ratio;
    const double x = ux(rng);
    data.points.push_back(outlier ? Eigen::Vector2d(box(rng), box(rng))
                                  : Eigen::Vector2d(x, 0.5 * x + 1.0 + gauss(rng)));
    data.is_outlier.push_back(outlier);
  }
  return data;
}

double LineAngleErrorDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::min(1.0, std::abs(a.head<2>().dot(b.head<2>())))) * 180.0 / M_PI;
}

TEST(Ransac, RecoversLineAndFlagsOutliers) {
  const LineData data = MakeLine(300, 0.45, 0.01, 1);
  RansacOptions options;
  options.inlier_threshold = 0.05;
  const auto result = Ransac(LineEstimator{}, std::span<const Eigen::Vector2d>(data.points), options);
  ASSERT_TRUE(result.success);
  EXPECT_LT(LineAngleErrorDeg(result.model, kTrueLine), 0.3);
  int mismatches = 0, inliers = 0;
  for (size_t i = 0; i < data.points.size(); ++i) {
    const bool truly_in = LineEstimator{}.Residual(kTrueLine, data.points[i]) < options.inlier_threshold;
    if (!data.is_outlier[i]) {
      EXPECT_TRUE(result.inlier_mask[i]) << i;
    }
    mismatches += (result.inlier_mask[i] != 0) != truly_in ? 1 : 0;
    inliers += result.inlier_mask[i];
  }
  EXPECT_LE(mismatches, 2);
  EXPECT_EQ(inliers, result.num_inliers);
}

TEST(Ransac, IterationFormula) {
  // log(0.001) / log(1 - 0.5^2) = 24.01 -> 25.
  EXPECT_EQ(RansacIterationsNeeded(0.5, 2, 0.999, 1000), 25);
  EXPECT_EQ(RansacIterationsNeeded(1.0, 5, 0.999, 1000), 1);
  EXPECT_EQ(RansacIterationsNeeded(0.0, 5, 0.999, 1000), 1000);
  EXPECT_EQ(RansacIterationsNeeded(0.1, 5, 0.999, 1000), 1000);  // 69075 needed, capped
  EXPECT_EQ(RansacIterationsNeeded(0.9, 3, 0.99, 1000), 4);      // log(0.01)/log(0.271) = 3.52
}

TEST(Ransac, AdaptiveIterationStopping) {
  RansacOptions options;
  options.inlier_threshold = 0.05;
  options.max_iterations = 5000;
  // No outliers: the first sample explains everything, one iteration suffices.
  const LineData clean = MakeLine(100, 0.0, 0.005, 2);
  auto r = Ransac(LineEstimator{}, std::span<const Eigen::Vector2d>(clean.points), options);
  ASSERT_TRUE(r.success);
  EXPECT_EQ(r.iterations, 1);
  // Half outliers: about 25 iterations (more if the early best models were poor).
  const LineData half = MakeLine(400, 0.5, 0.005, 3);
  r = Ransac(LineEstimator{}, std::span<const Eigen::Vector2d>(half.points), options);
  ASSERT_TRUE(r.success);
  const double w = static_cast<double>(r.num_inliers) / 400.0;
  EXPECT_GE(r.iterations, RansacIterationsNeeded(w, 2, 0.999, 5000) - 1);
  EXPECT_LT(r.iterations, 100);
  // min_iterations and max_iterations bound the count.
  options.min_iterations = 300;
  EXPECT_EQ(Ransac(LineEstimator{}, std::span<const Eigen::Vector2d>(half.points), options).iterations, 300);
  options.min_iterations = 0;
  options.max_iterations = 7;
  EXPECT_EQ(Ransac(LineEstimator{}, std::span<const Eigen::Vector2d>(half.points), options).iterations, 7);
}

TEST(Ransac, DeterministicForASeed) {
  const LineData data = MakeLine(200, 0.6, 0.01, 4);
  RansacOptions options;
  options.inlier_threshold = 0.05;
  const auto a = Ransac(LineEstimator{}, std::span<const Eigen::Vector2d>(data.points), options);
  const auto b = Ransac(LineEstimator{}, std::span<const Eigen::Vector2d>(data.points), options);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.model, b.model);
  EXPECT_EQ(a.inlier_mask, b.inlier_mask);
}

TEST(Ransac, LocalRefinementLowersCost) {
  const LineData data = MakeLine(500, 0.3, 0.03, 5);
  RansacOptions options;
  options.inlier_threshold = 0.12;
  const auto plain = Ransac(LineEstimator{}, std::span<const Eigen::Vector2d>(data.points), options);
  RefinableLineEstimator refinable;
  const auto refined = Ransac(refinable, std::span<const Eigen::Vector2d>(data.points), options);
  ASSERT_TRUE(plain.success && refined.success);
  EXPECT_GE(refinable.refine_calls, 1);
  EXPECT_LT(refined.cost, plain.cost);
  EXPECT_LT(LineAngleErrorDeg(refined.model, kTrueLine), 0.1);
  options.local_refinement = false;
  refinable.refine_calls = 0;
  const auto off = Ransac(refinable, std::span<const Eigen::Vector2d>(data.points), options);
  EXPECT_EQ(refinable.refine_calls, 0);
  EXPECT_EQ(off.model, plain.model);
}

TEST(Ransac, FailsCleanly) {
  RansacOptions options;
  options.inlier_threshold = 0.05;
  // Fewer points than a minimal sample.
  const std::vector<Eigen::Vector2d> one = {{1, 2}};
  auto r = Ransac(LineEstimator{}, std::span<const Eigen::Vector2d>(one), options);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.iterations, 0);
  EXPECT_EQ(r.inlier_mask.size(), 1u);
  // Only degenerate samples (all points equal): no model.
  const std::vector<Eigen::Vector2d> same(10, Eigen::Vector2d(3, 3));
  r = Ransac(LineEstimator{}, std::span<const Eigen::Vector2d>(same), options);
  EXPECT_FALSE(r.success);
  // A model exists but has fewer inliers than required.
  const LineData data = MakeLine(50, 0.0, 0.001, 6);
  options.min_inliers = 51;
  r = Ransac(LineEstimator{}, std::span<const Eigen::Vector2d>(data.points), options);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.num_inliers, 50);
  options = {};
  options.confidence = 1.0;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace glam
