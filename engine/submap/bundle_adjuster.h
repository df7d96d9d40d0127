// Bundle adjustment of one submap (thread 1, at every new keyframe): all keyframe poses and
// all landmark positions, plus each keyframe's focal length under a weak prior (the paper's
// focal length estimation: per-keyframe focal free in BA, the running median is used for
// tracking). Ceres with the Schur-complement sparse solver; cancellable through the token.
//
// Gauge: a monocular submap has 7 free DoF (pose + scale). The first keyframe's pose is held
// fixed, and the scale by fixing the largest-magnitude coordinate of the second keyframe's
// centre (the COLMAP convention), so the problem is well posed without priors.
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
  // Keyframes with index < fixed_keyframes keep their pose (gauge, or frozen history).
  int fixed_keyframes = 1;
  bool fix_scale = true;
  int num_threads = 1;

  void Check() const;
};

struct BundleAdjustmentSummary {
  double initial_rms_pixels = 0;
  double final_rms_pixels = 0;
  int iterations = 0;
  bool converged = false;
  double seconds = 0;
};

// Refines keyframes[*].cam_from_submap, keyframes[*].focal and landmarks[*].point_in_submap
// in place. Landmark observations index keyframes. `intrinsics` supplies cx, cy, k1, k2 and
// the aspect ratio fy / fx (kept fixed); each keyframe's focal is its fx. Throws Cancelled.
BundleAdjustmentSummary BundleAdjust(const Intrinsics& intrinsics, std::vector<Keyframe>& keyframes,
                                     std::vector<Landmark>& landmarks,
                                     const BundleAdjustmentOptions& options,
                                     const CancellationToken& cancel = {});

// Reprojection error (pixels) of one observation with the keyframe's own focal.
double ReprojectionError(const Intrinsics& intrinsics, const Keyframe& keyframe,
                         const Eigen::Vector3d& point_in_submap, const Eigen::Vector2f& pixel);

}  // namespace glam
