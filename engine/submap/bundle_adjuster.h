// Bundle adjustment of one submap (thread 1, at every new keyframe): all keyframe poses and
// all landmark positions, plus each keyframe's focal length under a weak prior (the paper's
// focal length estimation: per-keyframe focal free in BA, the running median is used for
// tracking). Ceres with the Schur-complement sparse solver; cancellable through the token.
//
// Gauge: a monocular submap has 7 free DoF (pose + scale). The first keyframe's pose is held
// fixed, and the scale by fixing the largest-magnitude coordinate of the second keyframe's
// centre (the COLMAP convention), so the problem is well posed without priors. A local
// adjustment (BundleAdjustmentOptions::local_keyframes) takes its gauge from the held older
// keyframes instead.
#pragma once

#include <vector>

#include "engine/core/camera.h"
#include "engine/core/cancellation.h"
#include "engine/map/keyframe.h"
#include "engine/map/landmark.h"

namespace glam {

struct BundleAdjustmentOptions {
  int max_iterations = 30;
  // Huber scale of the reprojection residual in pixels.
  double huber_pixels = 2.0;
  bool refine_focal = true;
  // Weight of the focal prior residual (f - f_prior) / f_prior; "weak": a 1 % focal change
  // costs as much as weight * 0.01 pixels of reprojection error.
  double focal_prior_weight = 10.0;
  // Centre of that prior (pixels). 0 = each keyframe's own focal before this adjustment. The
  // submap builder passes its running median: re-anchored at each keyframe's own last value,
  // the prior has no memory, and over a long submap the per-keyframe focals can walk away
  // together with their distances to the ground (a "dolly zoom" that the images barely
  // constrain on low relief); anchored at the common estimate, each keyframe pays for
  // deviating from what the others agree on.
  double focal_prior_px = 0.0;
  // One focal length for all keyframes of the adjustment instead of one each (the paper), with
  // the prior above on it; every keyframe gets the refined value (only with refine_focal:
  // fixed focals stay each keyframe's own). A single camera has a single
  // focal: per-keyframe focals let each keyframe trade its focal against its distance to the
  // ground, which on low relief and slow parallax walks the estimate away (measured: a 640x360
  // oblique loop at 100 m over 15 m relief, started 10 % long, drifted to +38 % per keyframe).
  bool share_focal = true;
  // One first radial distortion coefficient for all keyframes (COLMAP's SIMPLE_RADIAL model,
  // k2 stays the camera's), starting at intrinsics.k1 and held near it by the weak prior
  // k1_prior_weight * (k1 - intrinsics.k1): a change of 0.01 (1.6 px at the corner of a 60-deg
  // 640x360 frame) costs as much as 0.1 px of reprojection error. Why: consumer drone lenses
  // are rarely distortion-free, and an unmodelled k1 bends every submap (measured: k1 = -0.15
  // mapped as pinhole, ATE 1.7 m against 0.07 m with it known). Off for calibrated cameras.
  bool refine_k1 = true;
  double k1_prior_weight = 10.0;
  // Keyframes with index < fixed_keyframes keep their pose (gauge, or frozen history).
  int fixed_keyframes = 1;
  // Local adjustment (ORB-SLAM's local bundle adjustment): > 0 adjusts only the last
  // local_keyframes keyframes and the landmarks they observe; the older keyframes that observe
  // those landmarks are held and anchor them, and landmarks no adjusted keyframe sees are left
  // out. Falls back to the whole adjustment when fewer than two held keyframes each observe
  // at least local_min_anchor_observations of the adjusted landmarks (they fix the gauge:
  // pose and scale). 0 = every keyframe (from fixed_keyframes on).
  int local_keyframes = 0;
  int local_min_anchor_observations = 30;
  bool fix_scale = true;
  int num_threads = 1;
  // Ceres' linear solver: DENSE_SCHUR up to this many keyframes, SPARSE_SCHUR above. Both
  // eliminate the points and solve the same reduced camera system exactly; for the ~2-30
  // keyframes of a submap a dense Cholesky of it is cheaper than a sparse one (Ceres' own
  // advice for problems of a few cameras); the completion adjustment with every tracked frame
  // (hundreds of cameras) stays sparse. 0 = always sparse.
  int dense_schur_max_keyframes = 40;

  void Check() const;
};

struct BundleAdjustmentSummary {
  double initial_rms_pixels = 0;
  double final_rms_pixels = 0;
  int iterations = 0;
  bool converged = false;
  double seconds = 0;
  // The k1 the adjustment ended with (intrinsics.k1 unless refine_k1).
  double k1 = 0;
};

// Refines keyframes[*].cam_from_submap, keyframes[*].focal and landmarks[*].point_in_submap
// in place, and k1 (returned in the summary). Landmark observations index keyframes.
// `intrinsics` supplies cx, cy, k2 and the aspect ratio fy / fx (kept fixed) and the initial
// k1; each keyframe's focal is its fx. Throws Cancelled.
BundleAdjustmentSummary BundleAdjust(const Intrinsics& intrinsics, std::vector<Keyframe>& keyframes,
                                     std::vector<Landmark>& landmarks,
                                     const BundleAdjustmentOptions& options,
                                     const CancellationToken& cancel = {});

// Reprojection error (pixels) of one observation with the keyframe's own focal.
double ReprojectionError(const Intrinsics& intrinsics, const Keyframe& keyframe,
                         const Eigen::Vector3d& point_in_submap, const Eigen::Vector2f& pixel);

}  // namespace glam
