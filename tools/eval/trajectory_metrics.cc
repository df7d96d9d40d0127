#include "tools/eval/trajectory_metrics.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <optional>
#include <string>

#include "engine/core/error.h"
#include "engine/core/similarity_alignment.h"

namespace glam::eval {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;
constexpr int kMinMatched = 3;

std::vector<Eigen::Vector3d> Centres(const std::vector<SE3>& poses, std::size_t begin,
                                     std::size_t end) {
  std::vector<Eigen::Vector3d> centres;
  for (std::size_t k = begin; k < end; ++k) centres.push_back(poses[k].translation());
  return centres;
}

double RootMeanSquare(const std::vector<double>& values) {
  double sum_sq = 0;
  for (double v : values) sum_sq += v * v;
  return values.empty() ? 0.0 : std::sqrt(sum_sq / static_cast<double>(values.size()));
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0;
  const std::size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  double m = values[mid];
  if (values.size() % 2 == 0)
    m = 0.5 * (m + *std::max_element(values.begin(), values.begin() + mid));
  return m;
}

double RotationAngleDeg(const SO3& r) { return r.Log().norm() * kRadToDeg; }

// Applies a similarity to a camera pose: the centre moves with the full Sim3, the orientation
// only rotates (a camera frame has no scale).
SE3 Transform(const Sim3& g, const SE3& world_from_cam) {
  return SE3(g.rotation() * world_from_cam.rotation(), g * world_from_cam.translation());
}

// Scale of `estimate` relative to `gt` (estimate units per gt unit) on one stretch of the
// flight. Umeyama needs a non-collinear stretch for its rotation; a straight stretch still
// has a well-defined scale, the ratio of the spreads about the centroids.
std::optional<double> StretchScale(const std::vector<Eigen::Vector3d>& gt,
                                   const std::vector<Eigen::Vector3d>& estimate) {
  try {
    return AlignSimilarity(gt, estimate, /*estimate_scale=*/true).target_from_source.scale();
  } catch (const InputError&) {
  }
  const auto spread = [](const std::vector<Eigen::Vector3d>& points) {
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& p : points) mean += p;
    mean /= static_cast<double>(points.size());
    double sum_sq = 0;
    for (const auto& p : points) sum_sq += (p - mean).squaredNorm();
    return std::sqrt(sum_sq);
  };
  const double gt_spread = spread(gt);
  const double est_spread = spread(estimate);
  if (!(gt_spread > 1e-9) || !(est_spread > 1e-12)) return std::nullopt;
  return est_spread / gt_spread;
}

RelativePoseError ComputeRpe(const MatchedPoses& m, const std::vector<SE3>& aligned, double horizon,
                             double tolerance) {
  RelativePoseError rpe;
  rpe.horizon_s = horizon;
  const std::vector<double>& t = m.timestamps;
  if (t.empty() || horizon > t.back() - t.front() + tolerance) return rpe;
  std::vector<double> translation_errors;
  std::vector<double> rotation_errors;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const double target = t[i] + horizon;
    const auto it =
        std::lower_bound(t.begin() + static_cast<std::ptrdiff_t>(i), t.end(), target - tolerance);
    if (it == t.end() || *it > target + tolerance) continue;
    const std::size_t j = static_cast<std::size_t>(it - t.begin());
    if (j == i) continue;
    const SE3 gt_rel = m.gt_world_from_cam[i].Inverse() * m.gt_world_from_cam[j];
    const SE3 est_rel = aligned[i].Inverse() * aligned[j];
    const SE3 error = gt_rel.Inverse() * est_rel;
    translation_errors.push_back(error.translation().norm());
    rotation_errors.push_back(RotationAngleDeg(error.rotation()));
  }
  rpe.pairs = static_cast<int>(translation_errors.size());
  rpe.translation_rmse = RootMeanSquare(translation_errors);
  rpe.rotation_rmse_deg = RootMeanSquare(rotation_errors);
  return rpe;
}

std::string TimeSpan(const std::vector<TimedPose>& poses) {
  const auto [lo, hi] = std::minmax_element(
      poses.begin(), poses.end(),
      [](const TimedPose& a, const TimedPose& b) { return a.timestamp < b.timestamp; });
  return fmt::format("[{:.3f}, {:.3f}] s", lo->timestamp, hi->timestamp);
}

}  // namespace

void TrajectoryEvalOptions::Check() const {
  for (double h : rpe_horizons_s) {
    if (!(h > 0) || !std::isfinite(h)) {
      throw InputError(fmt::format("RPE horizon must be > 0 seconds, got {}", h));
    }
  }
}

MatchedPoses MatchByTimestamp(const std::vector<TimedPose>& gt,
                              const std::vector<TimedPose>& estimate, double tolerance) {
  std::vector<std::size_t> gt_order(gt.size()), est_order(estimate.size());
  std::iota(gt_order.begin(), gt_order.end(), 0);
  std::iota(est_order.begin(), est_order.end(), 0);
  std::stable_sort(gt_order.begin(), gt_order.end(),
                   [&](std::size_t a, std::size_t b) { return gt[a].timestamp < gt[b].timestamp; });
  std::stable_sort(est_order.begin(), est_order.end(), [&](std::size_t a, std::size_t b) {
    return estimate[a].timestamp < estimate[b].timestamp;
  });
  std::vector<bool> used(estimate.size(), false);
  MatchedPoses m;
  for (std::size_t g : gt_order) {
    const double t = gt[g].timestamp;
    const auto it =
        std::lower_bound(est_order.begin(), est_order.end(), t,
                         [&](std::size_t e, double v) { return estimate[e].timestamp < v; });
    // Nearest unused candidate: the first unused one after t and the first unused one
    // before t (est_order is sorted), whichever is closer.
    std::optional<std::size_t> best;
    double best_dt = tolerance;
    for (auto c = it; c != est_order.end() && estimate[*c].timestamp - t <= tolerance; ++c) {
      if (used[*c]) continue;
      best = *c;
      best_dt = estimate[*c].timestamp - t;
      break;
    }
    for (auto c = it; c != est_order.begin();) {
      --c;
      const double dt = t - estimate[*c].timestamp;
      if (dt > best_dt) break;
      if (used[*c]) continue;
      if (!best || dt < best_dt) best = *c;
      break;
    }
    if (!best) continue;
    used[*best] = true;
    m.timestamps.push_back(t);
    m.gt_world_from_cam.push_back(gt[g].world_from_cam);
    m.est_world_from_cam.push_back(estimate[*best].world_from_cam);
  }
  return m;
}

TrajectoryMetrics EvaluateTrajectory(const std::vector<TimedPose>& gt,
                                     const std::vector<TimedPose>& estimate, double match_tolerance,
                                     const TrajectoryEvalOptions& options) {
  options.Check();
  if (gt.empty()) throw InputError("the ground-truth trajectory is empty");
  if (estimate.empty()) throw InputError("the estimated trajectory is empty (no posed frames)");
  const MatchedPoses m = MatchByTimestamp(gt, estimate, match_tolerance);
  if (m.timestamps.empty()) {
    throw InputError(fmt::format(
        "no estimated pose overlaps the ground truth in time: ground truth spans {}, estimate "
        "spans {} (timestamps must be frame index / fps; match tolerance {:.4f} s)",
        TimeSpan(gt), TimeSpan(estimate), match_tolerance));
  }
  if (static_cast<int>(m.timestamps.size()) < kMinMatched) {
    throw InputError(
        fmt::format("only {} estimated pose(s) match ground-truth frames; at least {} "
                    "are needed to align the trajectories",
                    m.timestamps.size(), kMinMatched));
  }

  TrajectoryMetrics r;
  r.gt_frames = static_cast<int>(gt.size());
  r.estimated_poses = static_cast<int>(estimate.size());
  r.matched = static_cast<int>(m.timestamps.size());
  r.fraction_posed = static_cast<double>(r.matched) / r.gt_frames;
  r.scale_estimated = options.estimate_scale;

  const std::size_t n = m.timestamps.size();
  try {
    r.gt_from_estimate = AlignSimilarity(Centres(m.est_world_from_cam, 0, n),
                                         Centres(m.gt_world_from_cam, 0, n), options.estimate_scale)
                             .target_from_source;
  } catch (const InputError& e) {
    throw InputError(
        fmt::format("cannot align the estimated trajectory to ground truth: {}", e.what()));
  }

  std::vector<SE3> aligned;
  std::vector<double> centre_errors;
  std::vector<double> orientation_errors;
  for (std::size_t k = 0; k < n; ++k) {
    aligned.push_back(Transform(r.gt_from_estimate, m.est_world_from_cam[k]));
    centre_errors.push_back(
        (aligned[k].translation() - m.gt_world_from_cam[k].translation()).norm());
    orientation_errors.push_back(
        RotationAngleDeg(m.gt_world_from_cam[k].rotation().Inverse() * aligned[k].rotation()));
  }
  r.ate_rmse = RootMeanSquare(centre_errors);
  r.ate_mean =
      std::accumulate(centre_errors.begin(), centre_errors.end(), 0.0) / static_cast<double>(n);
  r.ate_median = Median(centre_errors);
  r.ate_max = *std::max_element(centre_errors.begin(), centre_errors.end());
  r.orientation_rmse_deg = RootMeanSquare(orientation_errors);

  for (double horizon : options.rpe_horizons_s) {
    r.rpe.push_back(ComputeRpe(m, aligned, horizon, match_tolerance));
  }

  const std::size_t third = n / 3;
  if (third >= 3) {
    r.scale_first_third = StretchScale(Centres(m.gt_world_from_cam, 0, third),
                                       Centres(m.est_world_from_cam, 0, third));
    r.scale_last_third = StretchScale(Centres(m.gt_world_from_cam, n - third, n),
                                      Centres(m.est_world_from_cam, n - third, n));
    if (r.scale_first_third && r.scale_last_third) {
      r.scale_drift_percent = std::abs(*r.scale_last_third / *r.scale_first_third - 1.0) * 100.0;
    }
  }
  return r;
}

}  // namespace glam::eval
