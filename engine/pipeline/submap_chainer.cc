#include "engine/pipeline/submap_chainer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <random>

#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/core/options.h"
#include "engine/core/similarity_alignment.h"
#include "engine/features/feature_matcher.h"

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

cv::Mat LandmarkDescriptors(const Submap& submap) {
  cv::Mat out(static_cast<int>(submap.landmarks.size()), kDescriptorSize, CV_32F);
  for (int i = 0; i < out.rows; ++i) {
    const Descriptor& d = submap.landmarks[static_cast<std::size_t>(i)].descriptor;
    float* row = out.ptr<float>(i);
    for (int j = 0; j < kDescriptorSize; ++j) row[j] = static_cast<float>(d[static_cast<std::size_t>(j)]) / 512.0f;
  }
  return out;
}

namespace {

std::vector<int> CountInliers(const Sim3& model, const std::vector<Eigen::Vector3d>& source,
                              const std::vector<Eigen::Vector3d>& target, double threshold) {
  std::vector<int> inliers;
  const double t2 = threshold * threshold;
  for (std::size_t i = 0; i < source.size(); ++i) {
    if ((model * source[i] - target[i]).squaredNorm() <= t2) inliers.push_back(static_cast<int>(i));
  }
  return inliers;
}

std::optional<SimilarityAlignmentResult> Fit(const std::vector<Eigen::Vector3d>& source,
                                             const std::vector<Eigen::Vector3d>& target,
                                             const std::vector<int>& rows) {
  std::vector<Eigen::Vector3d> s, t;
  s.reserve(rows.size());
  t.reserve(rows.size());
  for (int r : rows) {
    s.push_back(source[static_cast<std::size_t>(r)]);
    t.push_back(target[static_cast<std::size_t>(r)]);
  }
  try {
    return AlignSimilarity(s, t, true);
  } catch (const InputError&) {
    return std::nullopt;  // degenerate (collinear) sample
  }
}

}  // namespace

Sim3RansacResult EstimateSim3Ransac(const std::vector<Eigen::Vector3d>& source,
                                    const std::vector<Eigen::Vector3d>& target, double threshold,
                                    const ChainingOptions& options) {
  GLAM_CHECK(source.size() == target.size(), "correspondence sizes differ");
  Sim3RansacResult result;
  const int n = static_cast<int>(source.size());
  if (n < 3) return result;
  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::vector<int> best;
  int needed = options.max_iterations;
  for (int it = 0; it < needed; ++it) {
    int a = pick(rng), b = pick(rng), c = pick(rng);
    if (a == b || b == c || a == c) continue;
    const auto fit = Fit(source, target, {a, b, c});
    if (!fit) continue;
    std::vector<int> inliers = CountInliers(fit->target_from_source, source, target, threshold);
    if (inliers.size() > best.size()) {
      best = std::move(inliers);
      const double w = static_cast<double>(best.size()) / n;
      const double p_fail = 1.0 - w * w * w;
      if (p_fail <= 1e-12) {
        needed = it + 1;
      } else {
        const double k = std::log(1.0 - options.confidence) / std::log(p_fail);
        needed = std::min(options.max_iterations, static_cast<int>(std::ceil(k)) + 1);
      }
    }
  }
  if (best.size() < 3) return result;
  // Refit on all inliers, re-collect, refit once more (standard local optimisation).
  for (int round = 0; round < 2; ++round) {
    const auto fit = Fit(source, target, best);
    if (!fit) return result;
    std::vector<int> inliers = CountInliers(fit->target_from_source, source, target, threshold);
    if (inliers.size() < best.size() && round > 0) break;
    result.target_from_source = fit->target_from_source;
    result.inlier_rmse = fit->rmse;
    if (inliers.size() < 3) return result;
    best = std::move(inliers);
  }
  result.inliers = best;
  result.success = true;
  return result;
}

ChainResult LinkSubmaps(const Submap& previous, const Submap& next, const ChainingOptions& options) {
  ChainResult out;
  if (previous.landmarks.size() < 3 || next.landmarks.size() < 3) return out;
  MatchOptions match_options;
  match_options.ratio = options.match_ratio;
  match_options.mutual = options.mutual;
  const std::vector<Match> matches =
      MatchDescriptors(LandmarkDescriptors(next), LandmarkDescriptors(previous), match_options);
  out.matches = static_cast<int>(matches.size());
  std::vector<Eigen::Vector3d> source, target;
  source.reserve(matches.size());
  target.reserve(matches.size());
  for (const Match& m : matches) {
    source.push_back(next.landmarks[static_cast<std::size_t>(m.query)].point_in_submap);
    target.push_back(previous.landmarks[static_cast<std::size_t>(m.train)].point_in_submap);
  }
  const double threshold = options.inlier_threshold_fraction * SubmapScale(previous);
  const Sim3RansacResult ransac = EstimateSim3Ransac(source, target, threshold, options);
  out.inliers = static_cast<int>(ransac.inliers.size());
  out.inlier_rmse = ransac.inlier_rmse;
  const bool enough = ransac.success && out.inliers >= options.min_inliers &&
                      out.inliers >= options.min_inlier_ratio * out.matches;
  if (enough) {
    out.linked = true;
    out.prev_from_new = ransac.target_from_source;
  }
  GLAM_LOG_DEBUG("link submap {} -> {}: {} matches, {} inliers, rmse {:.4g} (threshold {:.4g}){}",
                 next.id, previous.id, out.matches, out.inliers, out.inlier_rmse, threshold,
                 enough ? "" : ": NOT linked");
  return out;
}

}  // namespace glam
