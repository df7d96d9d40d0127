// SubmapOptions::Check() accepts the defaults and names the option it rejects; the inlier
// thresholds scale with the first keyframe's feature count as documented.
#include <gtest/gtest.h>

#include "engine/core/error.h"
#include "engine/submap/submap_options.h"

namespace glam {
namespace {

void ExpectRejected(const SubmapOptions& options, const std::string& name) {
  try {
    options.Check();
    FAIL() << name << " accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
  }
}

TEST(SubmapOptions, DefaultsPass) { EXPECT_NO_THROW(SubmapOptions().Check()); }

TEST(SubmapOptions, RejectsABadEpipolarRatio) {
  SubmapOptions o;
  o.epipolar_match_ratio = 0;
  ExpectRejected(o, "epipolar_match_ratio");
  o.epipolar_match_ratio = 1.2;
  ExpectRejected(o, "epipolar_match_ratio");
}

TEST(SubmapOptions, RejectsBadMovingLandmarkOptions) {
  SubmapOptions o;
  o.moving_landmark_frames = -1;
  ExpectRejected(o, "moving_landmark_frames");
  o.moving_landmark_frames = 1;  // one rejection has no direction to keep
  ExpectRejected(o, "moving_landmark_frames");
  o = {};
  o.moving_landmark_min_cos = 1.5;
  ExpectRejected(o, "moving_landmark_min_cos");
  o = {};
  o.moving_landmark_frames = 0;  // the paper: every landmark is kept
  EXPECT_NO_THROW(o.Check());
}

TEST(SubmapOptions, RejectsBadFocalOptions) {
  SubmapOptions o;
  o.rebuild_focal_change = -0.01;
  ExpectRejected(o, "rebuild_focal_change");
  o = {};
  o.rebuild_focal_change = 1.5;
  ExpectRejected(o, "rebuild_focal_change");
  o = {};
  o.max_submap_rebuilds = -1;
  ExpectRejected(o, "max_submap_rebuilds");
  o = {};
  o.focal_prior_growth = -1;
  ExpectRejected(o, "focal_prior_growth");
  o = {};
  o.rebuild_focal_change = 0;  // the paper: never rebuild
  o.focal_prior_growth = 0;    // the paper: constant weak prior
  EXPECT_NO_THROW(o.Check());
}

TEST(SubmapOptions, RejectsBadBootstrapTwinOptions) {
  SubmapOptions o;
  o.bootstrap_twin_focal_step = -0.1;
  ExpectRejected(o, "bootstrap_twin_focal_step");
  o.bootstrap_twin_focal_step = 0.6;  // a fraction of the focal, below the 0.8-1.25 the guess spans
  ExpectRejected(o, "bootstrap_twin_focal_step");
  o = {};
  o.bootstrap_twin_check_keyframes = 2;  // the bootstrap's own two
  ExpectRejected(o, "bootstrap_twin_check_keyframes");
  o = {};
  o.bootstrap_twin_min_rms_gain = 1.0;
  ExpectRejected(o, "bootstrap_twin_min_rms_gain");
  o = {};
  o.bootstrap_twin_focal_step = 0;  // the paper: no check
  EXPECT_NO_THROW(o.Check());
}

TEST(SubmapOptions, RejectsBadParallaxRules) {
  SubmapOptions o;
  o.max_keyframe_parallax_deg = -1;
  ExpectRejected(o, "max_keyframe_parallax_deg");
  o = {};
  o.max_keyframe_parallax_deg = 1.5;  // below 2 x min_triangulation_angle_deg: cannot triangulate
  ExpectRejected(o, "max_keyframe_parallax_deg");
  o = {};
  o.bootstrap_accept_parallax_deg = 95;
  ExpectRejected(o, "bootstrap_accept_parallax_deg");
  o = {};
  o.min_map_coverage = -0.1;
  ExpectRejected(o, "min_map_coverage");
  o.min_map_coverage = 1.5;  // a fraction
  ExpectRejected(o, "min_map_coverage");
  o = {};
  o.max_keyframe_parallax_deg = 8;
  o.bootstrap_accept_parallax_deg = 6;
  EXPECT_NO_THROW(o.Check());
}

TEST(SubmapOptions, RejectsAShortFinalSubmapFractionOutsideZeroToOne) {
  SubmapOptions o;
  o.short_final_submap_fraction = -0.1;
  ExpectRejected(o, "short_final_submap_fraction");
  o.short_final_submap_fraction = 1.5;
  ExpectRejected(o, "short_final_submap_fraction");
  o.short_final_submap_fraction = 1.0;  // every final submap below keyframes_per_submap
  EXPECT_NO_THROW(o.Check());
}

TEST(SubmapOptions, ThresholdsScaleWithTheFirstKeyframesFeatures) {
  SubmapOptions o;
  EXPECT_EQ(o.EffectiveTauResection(o.reference_features), o.tau_resection);
  EXPECT_EQ(o.EffectiveTauStereo(2 * o.reference_features), o.tau_stereo);  // clamped at 1
  EXPECT_EQ(o.EffectiveTauStereo(o.reference_features / 2), o.tau_stereo / 2);
  // Never below 10 %, and resection always above the tracking-loss threshold.
  EXPECT_EQ(o.EffectiveTauStereo(1), o.tau_stereo / 10);
  EXPECT_GT(o.EffectiveTauResection(1), o.min_tracking_inliers);
}

}  // namespace
}  // namespace glam
