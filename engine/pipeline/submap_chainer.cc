#include "engine/pipeline/submap_chainer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/core/options.h"
#include "engine/features/feature_matcher.h"
#include "engine/geometry/similarity_ransac.h"
#include "engine/submap/frame_record.h"

namespace glam {

void ChainingOptions::Check() const {
  CheckInRange("ChainingOptions.match_ratio", match_ratio, 0.1f, 1.0f);
  CheckInRange("ChainingOptions.inlier_threshold_fraction", inlier_threshold_fraction, 1e-5, 1.0);
  CheckGreaterEqual("ChainingOptions.min_inliers", min_inliers, 3);
  CheckInRange("ChainingOptions.min_inlier_ratio", min_inlier_ratio, 0.0, 1.0);
  CheckGreater("ChainingOptions.max_iterations", max_iterations, 0);
  CheckInRange("ChainingOptions.confidence", confidence, 0.5, 0.999999);
}

double SubmapScale(const Submap& submap) {
  if (submap.keyframes.empty() || submap.landmarks.empty()) return 1.0;
  std::vector<Eigen::Vector3d> centres;
  centres.reserve(submap.keyframes.size());
  for (const Keyframe& kf : submap.keyframes) {
    centres.push_back(kf.cam_from_submap.Inverse().translation());
  }
  std::vector<double> distances;
  distances.reserve(submap.landmarks.size());
  for (const Landmark& lm : submap.landmarks) {
    double best = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector3d& c : centres) best = std::min(best, (lm.point_in_submap - c).norm());
    distances.push_back(best);
  }
  auto mid = distances.begin() + static_cast<std::ptrdiff_t>(distances.size() / 2);
  std::nth_element(distances.begin(), mid, distances.end());
  return *mid > 0 && std::isfinite(*mid) ? *mid : 1.0;
}

ChainResult LinkSubmaps(const Submap& previous, const Submap& next, const ChainingOptions& options) {
  ChainResult out;
  if (previous.landmarks.size() < 3 || next.landmarks.size() < 3) return out;
  MatchOptions match_options;
  match_options.ratio = options.match_ratio;
  match_options.mutual = options.mutual;
  const std::vector<Match> matches =
      MatchDescriptors(LandmarkDescriptorMatrix(next.landmarks),
                       LandmarkDescriptorMatrix(previous.landmarks), match_options);
  out.matches = static_cast<int>(matches.size());
  std::vector<PointCorrespondence> data;
  data.reserve(matches.size());
  for (const Match& m : matches) {
    data.push_back({next.landmarks[static_cast<std::size_t>(m.query)].point_in_submap,
                    previous.landmarks[static_cast<std::size_t>(m.train)].point_in_submap});
  }
  const double threshold = options.inlier_threshold_fraction * SubmapScale(previous);
  RansacOptions ransac_options;
  ransac_options.inlier_threshold = threshold;
  ransac_options.max_iterations = options.max_iterations;
  ransac_options.confidence = options.confidence;
  ransac_options.seed = options.seed;
  const RansacResult<Sim3> ransac = EstimateSimilarity(data, ransac_options);
  out.inliers = ransac.num_inliers;
  double sum_sq = 0;
  for (std::size_t i = 0; i < data.size(); ++i) {
    if (ransac.inlier_mask[i]) sum_sq += (ransac.model * data[i].source - data[i].target).squaredNorm();
  }
  out.inlier_rmse = out.inliers > 0 ? std::sqrt(sum_sq / out.inliers) : 0.0;
  const bool enough = ransac.success && out.inliers >= options.min_inliers &&
                      out.inliers >= options.min_inlier_ratio * out.matches;
  if (enough) {
    out.linked = true;
    out.prev_from_new = ransac.model;
  }
  GLAM_LOG_DEBUG("link submap {} -> {}: {} matches, {} inliers, rmse {:.4g} (threshold {:.4g}){}",
                 next.id, previous.id, out.matches, out.inliers, out.inlier_rmse, threshold,
                 enough ? "" : ": NOT linked");
  return out;
}

}  // namespace glam
