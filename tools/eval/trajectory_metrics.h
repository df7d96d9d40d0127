// Trajectory accuracy against ground truth, the numbers the GLAM paper and the usual SLAM
// benchmarks report: fraction of frames localised, ATE after similarity alignment (a
// monocular map has an arbitrary origin, orientation and scale, so only the shape can be
// judged), relative pose error over fixed time horizons (local drift, independent of the
// global alignment except for its scale), and scale drift between the start and the end of
// the flight (the characteristic failure of monocular mapping, invisible in a single
// global fit that averages it out).
#pragma once

#include <optional>
#include <vector>

#include "engine/core/se3.h"
#include "engine/core/sim3.h"
#include "engine/export/tum_trajectory.h"

namespace glam::eval {

// Ground-truth frames that have an estimated pose, in increasing time.
struct MatchedPoses {
  std::vector<double> timestamps;  // ground-truth timestamps
  std::vector<SE3> gt_world_from_cam;
  std::vector<SE3> est_world_from_cam;
};

// Pairs each ground-truth pose with the estimated pose nearest in time, if it is within
// `tolerance` seconds; an estimated pose is used at most once.
MatchedPoses MatchByTimestamp(const std::vector<TimedPose>& gt,
                              const std::vector<TimedPose>& estimate, double tolerance);

struct RelativePoseError {
  double horizon_s = 0;
  // Number of frame pairs (i, j) with t_j - t_i = horizon (within the match tolerance). Zero
  // when the horizon is longer than the matched trajectory: the metrics are then absent.
  int pairs = 0;
  double translation_rmse = 0;   // metres (estimate scaled by the alignment)
  double rotation_rmse_deg = 0;  // degrees
};

struct TrajectoryMetrics {
  int gt_frames = 0;
  int estimated_poses = 0;
  int matched = 0;
  double fraction_posed = 0;  // matched / gt_frames

  bool scale_estimated = true;
  Sim3 gt_from_estimate;  // alignment fitted on matched camera centres

  // Camera-centre error after alignment, metres.
  double ate_rmse = 0;
  double ate_mean = 0;
  double ate_median = 0;
  double ate_max = 0;
  // Orientation error after alignment, degrees (RMS of the angle of R_gt^T R_aligned).
  double orientation_rmse_deg = 0;

  std::vector<RelativePoseError> rpe;  // one per requested horizon, in the requested order

  // |s_last / s_first - 1| * 100 where s_k is the scale of the estimate relative to ground
  // truth (estimate units per metre) fitted on the first / last third of the matched frames.
  // Absent with fewer than 9 matched frames or if a third does not move.
  std::optional<double> scale_drift_percent;
  std::optional<double> scale_first_third;
  std::optional<double> scale_last_third;
};

struct TrajectoryEvalOptions {
  // Sim3 alignment (monocular); false aligns with SE3 (scale fixed to 1, for metric
  // estimates such as GPS-aided ones).
  bool estimate_scale = true;
  std::vector<double> rpe_horizons_s = {1.0, 10.0};

  // Throws InputError for a non-positive or non-finite horizon.
  void Check() const;
};

// `match_tolerance` is in seconds (half a frame period for frame-indexed timestamps).
// Throws InputError if either trajectory is empty, no estimated pose overlaps the ground
// truth in time, fewer than 3 poses match, or the matched estimated centres are degenerate
// (coincident or collinear) so that no alignment exists.
TrajectoryMetrics EvaluateTrajectory(const std::vector<TimedPose>& gt,
                                     const std::vector<TimedPose>& estimate, double match_tolerance,
                                     const TrajectoryEvalOptions& options);

}  // namespace glam::eval
