// One RANSAC loop for every robust estimation in GLAM (absolute pose, essential matrix, Sim3
// between submaps): the problem-specific parts live in an Estimator, the loop lives here once.
//
// An Estimator provides
//   using Datum = ...;                 one correspondence
//   using Model = ...;
//   static constexpr int kMinSampleSize;
//   std::vector<Model> Fit(std::span<const Datum> sample) const;   // 0..n models (empty =
//                                                                  // degenerate sample)
//   double Residual(const Model&, const Datum&) const;   // NOT squared, in the units of
//                                                        // RansacOptions::inlier_threshold
// and optionally
//   bool Refine(std::span<const Datum> inliers, Model* model) const;   // e.g. least squares
//
// Scoring is MSAC (Torr & Zisserman 2000): cost = sum_i min(r_i^2, t^2). Unlike counting
// inliers it prefers the model that fits its inliers tightly, at no extra cost.
// The iteration count adapts to the best inlier ratio w found so far:
//   N = log(1 - confidence) / log(1 - w^s),  clamped to [min_iterations, max_iterations].
// With a Refine(), the best model is re-estimated from its inliers (local optimisation) and the
// refit is kept only if it lowers the MSAC cost; this repeats while it helps (at most 4 times).
// Sampling uses a seeded generator: identical inputs give identical results.
#pragma once

#include <algorithm>
#include <cmath>
#include <concepts>
#include <cstdint>
#include <limits>
#include <random>
#include <span>
#include <vector>

namespace glam {

struct RansacOptions {
  int max_iterations = 1000;
  int min_iterations = 0;
  double confidence = 0.999;
  double inlier_threshold = 1.0;  // residual units of the estimator (pixels, metres, ...)
  // A result with fewer inliers (or fewer than the minimal sample) is reported as failure.
  int min_inliers = 0;
  bool local_refinement = true;
  uint64_t seed = 0;

  void Check() const;  // throws InputError
};

template <typename Model>
struct RansacResult {
  bool success = false;
  Model model{};
  std::vector<uint8_t> inlier_mask;  // one entry per datum, 1 = inlier
  int num_inliers = 0;
  int iterations = 0;  // hypotheses (samples) drawn
  double cost = std::numeric_limits<double>::infinity();  // MSAC cost of model
};

template <typename E>
concept RansacEstimator = requires(const E& e, std::span<const typename E::Datum> sample,
                                   const typename E::Model& model, const typename E::Datum& d) {
  { E::kMinSampleSize } -> std::convertible_to<int>;
  { e.Fit(sample) } -> std::same_as<std::vector<typename E::Model>>;
  { e.Residual(model, d) } -> std::convertible_to<double>;
};

template <typename E>
concept RefinableEstimator =
    RansacEstimator<E> && requires(const E& e, std::span<const typename E::Datum> inliers,
                                   typename E::Model* model) {
      { e.Refine(inliers, model) } -> std::same_as<bool>;
    };

// Iterations needed to draw one all-inlier sample of size s with the given confidence when a
// fraction w of the data are inliers.
int RansacIterationsNeeded(double inlier_ratio, int sample_size, double confidence,
                           int max_iterations);

namespace ransac_internal {

// MSAC cost of model over data; stops early (returns +inf) once the cost exceeds `bound`.
template <RansacEstimator E>
double Cost(const E& estimator, const typename E::Model& model,
            std::span<const typename E::Datum> data, double threshold, double bound,
            int* num_inliers) {
  const double t2 = threshold * threshold;
  double cost = 0.0;
  int inliers = 0;
  for (const auto& datum : data) {
    const double r = estimator.Residual(model, datum);
    const double r2 = r * r;  // NaN residuals count as outliers
    if (r2 < t2) {
      cost += r2;
      ++inliers;
    } else {
      cost += t2;
    }
    if (cost > bound) return std::numeric_limits<double>::infinity();
  }
  *num_inliers = inliers;
  return cost;
}

template <RansacEstimator E>
std::vector<typename E::Datum> Inliers(const E& estimator, const typename E::Model& model,
                                       std::span<const typename E::Datum> data, double threshold) {
  std::vector<typename E::Datum> inliers;
  for (const auto& datum : data) {
    if (estimator.Residual(model, datum) < threshold) inliers.push_back(datum);
  }
  return inliers;
}

}  // namespace ransac_internal

template <RansacEstimator E>
RansacResult<typename E::Model> Ransac(const E& estimator, std::span<const typename E::Datum> data,
                                       const RansacOptions& options) {
  options.Check();
  using Model = typename E::Model;
  using Datum = typename E::Datum;
  constexpr int s = E::kMinSampleSize;
  const int n = static_cast<int>(data.size());
  RansacResult<Model> result;
  result.inlier_mask.assign(data.size(), 0);
  if (n < s) return result;

  std::mt19937_64 rng(options.seed);
  std::vector<int> pool(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) pool[static_cast<size_t>(i)] = i;
  std::vector<Datum> sample(s);
  double best_cost = std::numeric_limits<double>::infinity();
  bool found = false;
  int needed = options.max_iterations;

  int it = 0;
  for (; it < std::max(needed, options.min_iterations) && it < options.max_iterations; ++it) {
    // Partial Fisher-Yates: the first s entries of pool become a uniform sample.
    for (int k = 0; k < s; ++k) {
      std::uniform_int_distribution<int> pick(k, n - 1);
      std::swap(pool[static_cast<size_t>(k)], pool[static_cast<size_t>(pick(rng))]);
      sample[static_cast<size_t>(k)] = data[static_cast<size_t>(pool[static_cast<size_t>(k)])];
    }
    for (const Model& model : estimator.Fit(std::span<const Datum>(sample))) {
      int inliers = 0;
      const double cost = ransac_internal::Cost(estimator, model, data, options.inlier_threshold,
                                                best_cost, &inliers);
      if (cost < best_cost) {
        best_cost = cost;
        result.model = model;
        found = true;
        needed = RansacIterationsNeeded(static_cast<double>(inliers) / n, s, options.confidence,
                                        options.max_iterations);
      }
    }
  }
  result.iterations = it;
  if (!found) return result;

  if constexpr (RefinableEstimator<E>) {
    for (int round = 0; options.local_refinement && round < 4; ++round) {
      const auto inliers =
          ransac_internal::Inliers(estimator, result.model, data, options.inlier_threshold);
      if (static_cast<int>(inliers.size()) < s) break;
      Model refined = result.model;
      if (!estimator.Refine(std::span<const Datum>(inliers), &refined)) break;
      int refined_inliers = 0;
      const double cost = ransac_internal::Cost(estimator, refined, data, options.inlier_threshold,
                                                best_cost, &refined_inliers);
      if (!(cost < best_cost)) break;
      const bool improved_a_lot = cost < best_cost * (1.0 - 1e-6);
      best_cost = cost;
      result.model = refined;
      if (!improved_a_lot) break;
    }
  }

  result.cost = best_cost;
  result.num_inliers = 0;
  for (int i = 0; i < n; ++i) {
    const bool inlier =
        estimator.Residual(result.model, data[static_cast<size_t>(i)]) < options.inlier_threshold;
    result.inlier_mask[static_cast<size_t>(i)] = inlier ? 1 : 0;
    result.num_inliers += inlier ? 1 : 0;
  }
  result.success = result.num_inliers >= std::max(options.min_inliers, s);
  return result;
}

}  // namespace glam
