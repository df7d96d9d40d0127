// Matching with a position prior: each query descriptor (e.g. a landmark projected with the
// previous frame's pose) is compared only with the features near its predicted pixel. Far
// fewer candidates than global matching, so it is both faster and less ambiguous; the ratio
// test is applied among the candidates inside the radius.
#pragma once

#include <limits>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "engine/features/feature_grid.h"
#include "engine/features/feature_matcher.h"

namespace glam {

struct GuidedMatchOptions {
  double radius_px = 20.0;
  // Best < ratio * second best among the candidates inside the radius. A lone candidate has
  // no second best and is accepted if it passes max_distance.
  float ratio = 0.8f;
  float max_distance = std::numeric_limits<float>::infinity();
  // When several queries pick the same feature, keep only the closest one.
  bool unique_train = true;

  void Check() const;  // throws InputError
};

// query_descriptors row i is searched around predicted[i] (non-finite: skipped) among the
// train features indexed by train_grid (whose point i has descriptor train_descriptors row i).
std::vector<Match> MatchGuided(const cv::Mat& query_descriptors,
                               const std::vector<Eigen::Vector2d>& predicted,
                               const cv::Mat& train_descriptors, const FeatureGrid& train_grid,
                               const GuidedMatchOptions& options = {});

// Squared L2 distance between two CV_32F rows of equal length.
float DescriptorDistanceSquared(const float* a, const float* b, int length);

}  // namespace glam
