#include "engine/features/guided_matcher.h"

#include <algorithm>
#include <cmath>

#include "engine/core/error.h"
#include "engine/core/options.h"

namespace glam {

void GuidedMatchOptions::Check() const {
  CheckGreater("GuidedMatchOptions.radius_px", radius_px, 0.0);
  CheckInRange("GuidedMatchOptions.ratio", ratio, 0.05f, 1.0f);
  CheckGreater("GuidedMatchOptions.max_distance", max_distance, 0.0f);
}

float DescriptorDistanceSquared(const float* a, const float* b, int length) {
  // Eigen vectorises the reduction (the compiler may not without -ffast-math).
  const Eigen::Map<const Eigen::VectorXf> va(a, length), vb(b, length);
  return (va - vb).squaredNorm();
}

std::vector<Match> MatchGuided(const cv::Mat& query_descriptors,
                               const std::vector<Eigen::Vector2d>& predicted,
                               const cv::Mat& train_descriptors, const FeatureGrid& train_grid,
                               const GuidedMatchOptions& options) {
  options.Check();
  GLAM_CHECK(static_cast<size_t>(query_descriptors.rows) == predicted.size(),
             "{} descriptors but {} predicted positions", query_descriptors.rows, predicted.size());
  GLAM_CHECK(static_cast<size_t>(train_descriptors.rows) == train_grid.size(),
             "{} train descriptors but {} grid points", train_descriptors.rows, train_grid.size());
  std::vector<Match> matches;
  if (query_descriptors.rows == 0 || train_descriptors.rows == 0) return matches;
  GLAM_CHECK(query_descriptors.type() == CV_32F && train_descriptors.type() == CV_32F &&
             query_descriptors.cols == train_descriptors.cols);
  const int dim = query_descriptors.cols;
  const float ratio2 = options.ratio * options.ratio;
  const float max2 = options.max_distance * options.max_distance;

  std::vector<int> candidates;
  for (int q = 0; q < query_descriptors.rows; ++q) {
    candidates.clear();
    train_grid.Query(predicted[static_cast<size_t>(q)], options.radius_px, &candidates);
    if (candidates.empty()) continue;
    const float* qd = query_descriptors.ptr<float>(q);
    float best = std::numeric_limits<float>::infinity(), second = best;
    int best_index = -1;
    for (int c : candidates) {
      const float d = DescriptorDistanceSquared(qd, train_descriptors.ptr<float>(c), dim);
      if (d < best) {
        second = best;
        best = d;
        best_index = c;
      } else if (d < second) {
        second = d;
      }
    }
    if (best > max2) continue;
    if (candidates.size() > 1 && options.ratio < 1.0f && !(best < ratio2 * second)) continue;
    matches.push_back({q, best_index, std::sqrt(best)});
  }
  if (!options.unique_train) return matches;

  // Keep the closest query per train feature.
  std::vector<int> owner(train_grid.size(), -1);
  for (size_t i = 0; i < matches.size(); ++i) {
    int& o = owner[static_cast<size_t>(matches[i].train)];
    if (o < 0 || matches[i].distance < matches[static_cast<size_t>(o)].distance) o = static_cast<int>(i);
  }
  std::vector<Match> unique;
  unique.reserve(matches.size());
  for (size_t i = 0; i < matches.size(); ++i) {
    if (owner[static_cast<size_t>(matches[i].train)] == static_cast<int>(i)) unique.push_back(matches[i]);
  }
  return unique;
}

}  // namespace glam
