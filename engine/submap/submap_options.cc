#include "engine/submap/submap_options.h"

#include <algorithm>
#include <cmath>

#include "engine/core/options.h"

namespace glam {
namespace {

int Scaled(int tau, int features, int reference) {
  const double ratio = std::clamp(static_cast<double>(features) / reference, 0.1, 1.0);
  return std::max(1, static_cast<int>(std::lround(tau * ratio)));
}

}  // namespace

void SubmapOptions::Check() const {
  CheckGreater("SubmapOptions.tau_resection", tau_resection, 0);
  CheckGreater("SubmapOptions.tau_stereo", tau_stereo, 0);
  CheckInRange("SubmapOptions.alpha_stereo_deg", alpha_stereo_deg, 1.0, 90.0);
  CheckGreaterEqual("SubmapOptions.keyframes_per_submap", keyframes_per_submap, 3);
  CheckGreaterEqual("SubmapOptions.local_ba_keyframes", local_ba_keyframes, 0);
  CheckInRange("SubmapOptions.overlap_fraction", overlap_fraction, 0.0, 0.5);
  CheckGreater("SubmapOptions.reference_features", reference_features, 0);
  CheckInRange("SubmapOptions.min_bootstrap_parallax_deg", min_bootstrap_parallax_deg, 0.1, 30.0);
  CheckGreater("SubmapOptions.max_bootstrap_frames", max_bootstrap_frames, 1);
  CheckInRange("SubmapOptions.bootstrap_accept_parallax_deg", bootstrap_accept_parallax_deg, 0.0, 90.0);
  CheckInRange("SubmapOptions.hover_max_speed", hover_max_speed, 0.0, 1.0);
  CheckInRange("SubmapOptions.hover_min_rotation_fraction", hover_min_rotation_fraction, 0.0, 1.0);
  CheckInRange("SubmapOptions.hover_max_seconds", hover_max_seconds, 0.0, 3600.0);
  CheckInRange("SubmapOptions.hover_min_turn_rate_deg_s", hover_min_turn_rate_deg_s, 0.0, 3600.0);
  CheckInRange("SubmapOptions.bootstrap_rotation_veto_fraction", bootstrap_rotation_veto_fraction, 0.0, 1.0);
  CheckInRange("SubmapOptions.bootstrap_twin_focal_step", bootstrap_twin_focal_step, 0.0, 0.5);
  CheckGreaterEqual("SubmapOptions.bootstrap_twin_check_keyframes", bootstrap_twin_check_keyframes, 3);
  CheckInRange("SubmapOptions.bootstrap_twin_min_rms_gain", bootstrap_twin_min_rms_gain, 0.0, 0.9);
  CheckInRange("SubmapOptions.bootstrap_rotation_veto_pixels", bootstrap_rotation_veto_pixels, 0.1, 10.0);
  CheckGreaterEqual("SubmapOptions.min_tracking_inliers", min_tracking_inliers, 6);
  CheckInRange("SubmapOptions.max_view_angle_deg", max_view_angle_deg, 1.0, 180.0);
  CheckInRange("SubmapOptions.match_radius_fraction", match_radius_fraction, 0.001, 1.0);
  CheckInRange("SubmapOptions.match_ratio", match_ratio, 0.1, 1.0);
  CheckInRange("SubmapOptions.epipolar_match_ratio", epipolar_match_ratio, 0.1, 1.0);
  CheckGreater("SubmapOptions.pnp_threshold_pixels", pnp_threshold_pixels, 0.0);
  CheckInRange("SubmapOptions.moving_landmark_frames", moving_landmark_frames, 0, 1000);
  if (moving_landmark_frames == 1) {
    throw InputError("SubmapOptions.moving_landmark_frames must be 0 (off) or at least 2: the direction "
                     "and growth of a residual are judged against the previous rejection's");
  }
  CheckInRange("SubmapOptions.moving_landmark_min_cos", moving_landmark_min_cos, -1.0, 1.0);
  CheckInRange("SubmapOptions.min_triangulation_angle_deg", min_triangulation_angle_deg, 0.0, 45.0);
  CheckInRange("SubmapOptions.max_keyframe_parallax_deg", max_keyframe_parallax_deg, 0.0, 90.0);
  CheckInRange("SubmapOptions.min_map_coverage", min_map_coverage, 0.0, 1.0);
  CheckGreater("SubmapOptions.max_new_point_reprojection_pixels", max_new_point_reprojection_pixels, 0.0);
  CheckGreaterEqual("SubmapOptions.max_frames_per_submap", max_frames_per_submap, 10);
  CheckGreaterEqual("SubmapOptions.completion_ba_max_frames", completion_ba_max_frames, 0);
  CheckInRange("SubmapOptions.rebuild_focal_change", rebuild_focal_change, 0.0, 1.0);
  CheckGreaterEqual("SubmapOptions.max_submap_rebuilds", max_submap_rebuilds, 0);
  CheckGreaterEqual("SubmapOptions.focal_prior_growth", focal_prior_growth, 0.0);
  CheckInRange("SubmapOptions.focal_profile_step", focal_profile_step, 0.0, 0.5);
  CheckInRange("SubmapOptions.focal_profile_min_rms_increase", focal_profile_min_rms_increase, 0.0, 0.1);
  CheckInRange("SubmapOptions.k1_profile_min_rms_increase", k1_profile_min_rms_increase, 0.0, 0.5);
  CheckInRange("SubmapOptions.readout_max_ms", readout_max_ms, 1.0, 100.0);
  CheckInRange("SubmapOptions.readout_step_ms", readout_step_ms, 0.5, readout_max_ms);
  CheckInRange("SubmapOptions.readout_min_rms_gain", readout_min_rms_gain, 0.0, 0.5);
  CheckInRange("SubmapOptions.readout_max_submaps", readout_max_submaps, 1, 1000);
  CheckInRange("SubmapOptions.short_final_submap_fraction", short_final_submap_fraction, 0.0, 1.0);
  if (max_keyframe_parallax_deg > 0 && max_keyframe_parallax_deg < 2.0 * min_triangulation_angle_deg) {
    throw InputError("SubmapOptions.max_keyframe_parallax_deg must be 0 or at least twice "
                     "min_triangulation_angle_deg (a keyframe must be able to triangulate)");
  }
  if (min_tracking_inliers >= tau_resection) {
    throw InputError("SubmapOptions.min_tracking_inliers must be below tau_resection");
  }
  bundle_adjustment.Check();
  outlier_filter.Check();
  centre_smoothing.Check();
}

int SubmapOptions::EffectiveTauResection(int features) const {
  return std::max(Scaled(tau_resection, features, reference_features), min_tracking_inliers + 1);
}

int SubmapOptions::EffectiveTauStereo(int features) const {
  return Scaled(tau_stereo, features, reference_features);
}

}  // namespace glam
