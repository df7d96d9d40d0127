// Closed-form similarity between corresponding point sets (Umeyama 1991, via
// Eigen::umeyama). Used for evaluation (ATE after Sim3 alignment), for levelling and as the
// minimal/refit solver of Sim3 RANSAC between submaps.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "engine/core/sim3.h"

namespace glam {

struct SimilarityAlignmentResult {
  Sim3 target_from_source;
  // sqrt(mean ||target_from_source * source_i - target_i||^2).
  double rmse = 0;
};

// Least-squares Sim3 (or SE3 with scale fixed to 1 if !estimate_scale) mapping source[i]
// onto target[i]. Throws InputError if the sizes differ, there are fewer than 3 points, a
// coordinate is not finite, or the source points are degenerate (all coincident or
// collinear, so the rotation is not determined).
SimilarityAlignmentResult AlignSimilarity(const std::vector<Eigen::Vector3d>& source,
                                          const std::vector<Eigen::Vector3d>& target,
                                          bool estimate_scale = true);

}  // namespace glam
