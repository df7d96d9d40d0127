// Sim3 between two sets of corresponding 3D points (overlap landmarks of consecutive submaps,
// loop-closure candidates): closed-form Umeyama (AlignSimilarity) on 3-point samples inside
// glam::Ransac, then on all inliers. Residual = ||target - T * source|| in target units.
#pragma once

#include <span>
#include <vector>

#include <Eigen/Core>

#include "engine/core/sim3.h"
#include "engine/geometry/ransac.h"

namespace glam {

struct PointCorrespondence {
  Eigen::Vector3d source;
  Eigen::Vector3d target;
};

class SimilarityEstimator {
 public:
  using Datum = PointCorrespondence;
  using Model = Sim3;  // target_from_source
  static constexpr int kMinSampleSize = 3;

  // estimate_scale = false fits a rigid transform (scale 1) instead.
  explicit SimilarityEstimator(bool estimate_scale = true) : estimate_scale_(estimate_scale) {}

  std::vector<Sim3> Fit(std::span<const Datum> sample) const;
  double Residual(const Sim3& target_from_source, const Datum& d) const {
    return (d.target - target_from_source * d.source).norm();
  }
  bool Refine(std::span<const Datum> inliers, Sim3* target_from_source) const;

 private:
  bool estimate_scale_;
};

// options.inlier_threshold in target units.
RansacResult<Sim3> EstimateSimilarity(std::span<const PointCorrespondence> data,
                                      const RansacOptions& options, bool estimate_scale = true);

}  // namespace glam
