#include "engine/geometry/similarity_ransac.h"

#include <algorithm>
#include <optional>

#include "engine/core/error.h"
#include "engine/core/similarity_alignment.h"

namespace glam {
namespace {

// Nearly collinear (or coincident) source or target points: the rotation about the line is
// undetermined. Checked here so that degenerate samples do not cost an exception.
bool Degenerate(std::span<const PointCorrespondence> sample) {
  auto flat = [&](auto get) {
    const Eigen::Vector3d a = get(sample[1]) - get(sample[0]);
    const Eigen::Vector3d b = get(sample[2]) - get(sample[0]);
    const double scale = std::max(a.squaredNorm(), b.squaredNorm());
    return !(a.cross(b).norm() > 1e-6 * scale) || !(scale > 0);
  };
  return flat([](const PointCorrespondence& c) { return c.source; }) ||
         flat([](const PointCorrespondence& c) { return c.target; });
}

std::optional<Sim3> Align(std::span<const PointCorrespondence> data, bool estimate_scale) {
  std::vector<Eigen::Vector3d> source, target;
  source.reserve(data.size());
  target.reserve(data.size());
  for (const auto& d : data) {
    source.push_back(d.source);
    target.push_back(d.target);
  }
  try {
    return AlignSimilarity(source, target, estimate_scale).target_from_source;
  } catch (const InputError&) {
    return std::nullopt;  // degenerate configuration
  }
}

}  // namespace

std::vector<Sim3> SimilarityEstimator::Fit(std::span<const Datum> sample) const {
  if (Degenerate(sample)) return {};
  const auto model = Align(sample, estimate_scale_);
  if (!model) return {};
  return {*model};
}

bool SimilarityEstimator::Refine(std::span<const Datum> inliers, Sim3* target_from_source) const {
  const auto model = Align(inliers, estimate_scale_);
  if (!model) return false;
  *target_from_source = *model;
  return true;
}

RansacResult<Sim3> EstimateSimilarity(std::span<const PointCorrespondence> data,
                                      const RansacOptions& options, bool estimate_scale) {
  return Ransac(SimilarityEstimator(estimate_scale), data, options);
}

}  // namespace glam
