// Options of thread 1 (local submap creation), defaults from the GLAM paper where it gives
// them. Inlier thresholds in the paper (tau_resection = 500, tau_stereo = 1000) were tuned on
// 1-megapixel frames with many features; here they scale with the number of features of the
// submap's first keyframe:
//     effective_tau = tau * clamp(first_keyframe_features / reference_features, 0.1, 1)
// so the paper's values apply at `reference_features` (4000, SIFT at contrast 0.01 on a
// 1-megapixel aerial frame) and smaller frames get proportionally smaller thresholds.
#pragma once

#include "engine/submap/bundle_adjuster.h"
#include "engine/submap/centre_smoothing.h"
#include "engine/submap/outlier_filter.h"

namespace glam {

struct SubmapOptions {
  // --- paper parameters ---
  int tau_resection = 500;             // PnP inliers below this -> new keyframe
  int tau_stereo = 1000;               // bootstrap: essential inliers below this -> 2nd keyframe
  double alpha_stereo_deg = 30.0;      // bootstrap: mean triangulation angle above this -> 2nd keyframe
  int keyframes_per_submap = 20;       // completion
  double overlap_fraction = 0.10;      // next submap starts at the last 10 % of frames

  // --- scaling of the thresholds (see file comment) ---
  int reference_features = 4000;

  // --- bootstrap ---
  // Never take the second keyframe before the median triangulation angle reaches this: below
  // ~2 degrees depth is too uncertain to start a map.
  double min_bootstrap_parallax_deg = 2.0;
  // Give up on a first keyframe after this many frames and restart the bootstrap (e.g. a
  // hovering drone): the best candidate seen so far is taken if it has enough parallax.
  int max_bootstrap_frames = 90;
  // Also take the second keyframe once the median triangulation angle reaches this, even
  // while the essential inliers are still above tau_stereo (the scaled tau_stereo of a small
  // frame can hold the bootstrap for 80-90 frames and 15 deg). 0 = the paper's rule alone.
  // With max_keyframe_parallax_deg = 8: 3 submaps instead of 2 on lawnmower seeds 2-4, and
  // with the default feature grid map medians 0.18-0.27 % of altitude on seeds 1-4
  // (docs/algorithm.md).
  double bootstrap_accept_parallax_deg = 6.0;
  // A candidate pair of which a pure rotation (with a focal scale of 0.8-1.25) explains at
  // least this fraction of the essential inliers to within bootstrap_rotation_veto_pixels has
  // no usable baseline, whatever angle its essential matrix triangulates: a hovering, yawing
  // drone gives such pairs, and E is degenerate on them (engine/geometry/rotation_only.h). The
  // bootstrap waits for parallax instead. Measured on a flight 45 deg from nadir hovering
  // through a 180-deg yaw: a submap bootstrapped on two hover frames (E said 2.1 deg) came out
  // 2.7 m wrong; that pair scores 0.88, candidates of real motion on the benchmark videos 0.10
  // to 0.70 (nadir 40-100 m, 2-8 deg; small nadir steps look most like a rotation), and a
  // vetoed true candidate only makes the bootstrap wait for more parallax. 0 = off (the paper).
  double bootstrap_rotation_veto_fraction = 0.8;
  double bootstrap_rotation_veto_pixels = 1.0;
  // Twin check of the first submap while the focal is estimated. Nearly planar ground has two
  // relative motions that explain a view pair almost equally well, and which one the
  // bootstrap's RANSAC finds can hang on a few per cent of focal. Measured on a 640x360 loop
  // 60 deg from nadir at 40 m, uncalibrated: at the initial 512 px (truth 554) the wrong motion
  // won, the submap built on it settled at 525 px and 0.59 px rms (0.33 px at the truth) and
  // the flight came out 1.9 m ATE, 68 % posed; at 525-700 px the right one won. So when the
  // motion found at (1 -/+ bootstrap_twin_focal_step) x the focal lies in another basin
  // (kDistinctMotionDeg), the open submap, once it has bootstrap_twin_check_keyframes
  // keyframes, is tracked again from its first frame starting at that focal with the
  // bootstrap steered to that motion; the second build is kept only if its bundle
  // adjustment's rms is lower by at least bootstrap_twin_min_rms_gain (relative), otherwise
  // the first is restored. Rebuilds from the same first frame keep the motion kept. One extra
  // build of a few keyframes, once per run (calibrated runs never). 0 = off (the paper).
  double bootstrap_twin_focal_step = 0.15;
  int bootstrap_twin_check_keyframes = 6;
  double bootstrap_twin_min_rms_gain = 0.05;

  // --- tracking ---
  // Fewer PnP inliers than this (absolute) -> tracking lost: close the submap, start anew.
  int min_tracking_inliers = 40;
  // Landmarks seen from a direction this far from their first viewing direction are not
  // matched (SIFT is not invariant to large viewpoint changes).
  double max_view_angle_deg = 45.0;
  // Search radius for matching projected landmarks, as a fraction of the image diagonal.
  double match_radius_fraction = 0.04;
  double match_ratio = 0.8;            // Lowe's ratio for descriptor matches
  double pnp_threshold_pixels = 3.0;   // RANSAC inlier threshold (processing resolution)
  // Landmarks on content that moves on its own. A ripple on water or the edge of a cloud
  // shadow drifts 1-3 px between keyframes, inside every threshold, so it is triangulated like
  // ground; as it drifts on, tracking keeps matching its descriptor and PnP rejects it, with a
  // residual that points the way it drifts and grows. A landmark that PnP rejects this many
  // times in a row (frames that do not match it at all do not break the run; an inlier does),
  // each residual within acos(moving_landmark_min_cos) of the previous one's direction and
  // longer than it, is removed from the open submap before the next bundle adjustment, unless
  // it became an inlier again meanwhile (then it was the pose that had drifted). ORB-SLAM culls
  // recent points its tracking does not confirm; counting every rejection instead of only
  // directional ones broke a 40 m cloud-shadow loop (0.19 -> 2.9 m), and a mismatch has
  // residuals in random directions. Measured, calibrated (docs/benchmarks.md, "Content that
  // moves on its own"): a 40 m loop over 19 % drifting water 0.408 -> 0.178 m ATE, a coast
  // whose first 4 s are 85 % water 2.93 -> 0.30 m (those 4 s become a part of their own),
  // the cloud-shadow loop 0.193 -> 0.126 m; the 23 static robustness clips 2.025 -> 2.082 m
  // summed (uncalibrated 3.459 -> 3.220 m). 0 = off (the paper).
  int moving_landmark_frames = 3;
  double moving_landmark_min_cos = 0.8;

  // --- hovering yaw (tracking_rotation.cc) ---
  // A drone that stops and yaws in place with an oblique camera turns its view to ground no
  // landmark covers, and PnP fails. When that happens right after a hover (the camera centre
  // moved less than hover_max_speed x the median landmark depth per second between the posed
  // frames 0.7 and 0.2 s before, by a line fitted through their centres; PnP of the last
  // frames before the loss degrades, measured up to 0.75 m off), the frame is posed by
  // rotation only: the mean centre of those hover frames, and the rotation that maps the
  // previous frame's features onto this one's (a pure-rotation
  // fit explaining at least hover_min_rotation_fraction of the descriptor matches to within
  // RotationOnlyOptions::inlier_threshold_px, 1 px). Frame after frame, for at most
  // hover_max_seconds and while the camera turns (hover_min_turn_rate_deg_s); the first frame
  // that neither PnP nor the rotation poses loses tracking as before, and the next submap is
  // bootstrapped from the chain's first frame (the chain's frames are replayed into it). Such
  // frames never become keyframes and add no landmarks. On the PnP jitter of a yawing oblique
  // camera, hovers measured 0.003-0.010 and a drone accelerating away 0.019 (x depth per
  // second). Measured on a 45-deg oblique flight hovering through 180-deg yaws: 87.0 -> 97.8 %
  // of the frames in the map, ATE 0.22 -> 0.17 m (docs/benchmarks.md, "Stop-and-yaw
  // flights"). 0 = off (the paper: tracking is lost).
  double hover_max_speed = 0.01;
  double hover_min_rotation_fraction = 0.5;
  double hover_max_seconds = 10.0;
  // The chain also ends where the camera turns slower than this (degrees per second): a pure
  // rotation fit between consecutive frames cannot tell a slow flight over distant ground from
  // a hover (measured: a drone flying off at 5 m/s, 85 m from the ground, leaves ~0.3 px that
  // no rotation explains), so a frame is posed by rotation only while the drone is visibly
  // turning, which is what took its landmarks out of view.
  double hover_min_turn_rate_deg_s = 10.0;

  // --- triangulation of new landmarks ---
  // New keyframes also wait until the parallax to the previous keyframe is twice this, so the
  // middle keyframe / current frame pair can triangulate.
  double min_triangulation_angle_deg = 1.0;
  // A detected frame whose median parallax to the last keyframe reaches this becomes a
  // keyframe even while its PnP inliers are above tau_resection (the submap's landmarks can
  // cover the view for 200+ frames, so the paper's rule alone spreads keyframes thinly).
  // 0 = the paper's rule alone.
  double max_keyframe_parallax_deg = 8.0;
  // A detected frame of which the submap's landmarks, projected with its pose, cover less than
  // this fraction of the textured view (MapCoverage, engine/submap/frame_record.h) becomes a
  // keyframe once it can triangulate with the last one. A drone climbing over its take-off
  // point keeps its landmarks in view and tracked, so neither the inlier count nor their
  // parallax asks for a keyframe, while the unmapped ground around them grows: measured on a
  // nadir climb from 30 to 100 m, coverage fell from 0.60 to 0.15, no keyframe was taken for
  // 440 frames, and frames were posed from ~100 central landmarks (errors up to 1.8 m, ATE
  // 0.50 m; with the rule 0.11 m). In level flight the other rules keep it at 0.42-1.0 on
  // nadir clips and the 60-deg oblique one (whose far field is never triangulated); of 25
  // non-climb clips one changes (a 25 m flight, ATE 0.062 -> 0.088 m; docs/benchmarks.md).
  // 0 = off (the paper).
  double min_map_coverage = 0.35;
  double max_new_point_reprojection_pixels = 3.0;
  // How the middle keyframe and the current frame are matched for triangulation. Both are
  // posed by PnP, so a feature's match can only lie near its epipolar line: true compares each
  // feature only with the other frame's features within max_new_point_reprojection_pixels of
  // that line and in front of both cameras (MatchAlongEpipolarLines,
  // engine/features/epipolar_matcher.h); false (default) = the paper: global descriptor
  // matching, then an essential-matrix RANSAC to select the consistent matches. On by
  // UseCalibration (engine/pipeline/mapping_options.h), off otherwise, and used only while the
  // focal and k1 are fixed (not with --refine-focal): the lines are drawn with the camera
  // model, and while the focal and k1 are still being estimated they miss the true matches
  // (uncalibrated, on the 23 robustness clips: pitch60 and crf32 fell apart, 6 others got
  // worse; with --refine-focal from a 16 % short EXIF focal, 6 of the 18 Brighton Beach
  // photos were lost). Calibrated, on the loop benchmark video: 2.2 s of matching and RANSAC -> ~0.2 s;
  // ATE lower on two of the four benchmark videos, within 0.004 m on the others
  // (docs/benchmarks.md).
  bool epipolar_triangulation_matching = false;
  // Lowe's ratio among the candidates along an epipolar line (match_ratio is the global one).
  // The band holds ~1 % of the frame's features, so its second best is usually farther than a
  // global second best and the same ratio lets more ambiguous matches through: at 0.8, the
  // compressed benchmark video got 36 % more landmarks but 70 % more with errors > 1 m; at 0.7,
  // 23 % more landmarks, ATE 0.160 -> 0.146 m (docs/benchmarks.md).
  double epipolar_match_ratio = 0.7;
  // Duplicate removal compares a new landmark's descriptor only with the existing landmarks
  // that project into the first frame of its pair (where a duplicate of it would have to be);
  // false = with every landmark of the submap (the paper). A 20-keyframe submap of the loop
  // benchmark video holds ~5000 landmarks, a frame sees about a third of them: the check
  // (a kd-tree over the compared landmarks, built per keyframe pair) cost 22 ms per pair with
  // all of them.
  bool duplicate_check_in_view = true;
  // Look for new landmarks in earlier keyframes too (longer tracks). Off by default: on
  // repetitive texture it adds wrong observations faster than it adds baseline (measured on
  // the synthetic lawnmower clip: map median error 0.29 m -> 0.9 m).
  bool extend_new_tracks = false;

  // The isolated-point filter (outlier filter 2) after each bundle adjustment tests only the
  // landmarks triangulated since the previous one; the completion pass tests all. The paper
  // tests all after every adjustment, but the filter is relative (mean + 2 sigma of the
  // k-nearest-neighbour distance), so it removes the sparsest ~5 % every time whether they are
  // outliers or not, and repeated at every keyframe it wears down thinly mapped ground: on the
  // loop benchmark video the frames after one submap's two-view start lost 44 % of their
  // landmarks to it, all on one side of the image, and their poses went 0.5 m wrong. Measured
  // (calibrated, ATE): benchmark videos lawnmower / loop / oblique 0.090 / 0.067 / 0.197 m ->
  // 0.088 / 0.052 / 0.149 m; docs/algorithm.md has the other clips. false = the paper.
  bool isolated_filter_once = true;

  // The bundle adjustment after each new keyframe adjusts only the last local_ba_keyframes
  // keyframes (three keyframe insertions: each adds the middle keyframe and the current
  // frame) and the landmarks they see, held in place by the older keyframes that see them too
  // (BundleAdjustmentOptions::local_keyframes; ORB-SLAM's local bundle adjustment); the
  // completion adjustment is always the whole submap. Only while the camera is fixed
  // (calibrated, or the focal and k1 decided and held): an estimate still moving couples every
  // keyframe. Why: the adjustments after each keyframe were the largest part of the submap
  // builder's time (loop benchmark video, 114 keyframes: 8.1 of 14.2 s), and a keyframe's
  // adjustment barely moves keyframes six insertions back. Measured on the four benchmark
  // videos, calibrated, interleaved with the whole adjustment: bundle adjustment 8.1 -> 5.7 s
  // (loop), builder 14.2 -> 11.4 s, wall -14 % (loop), -7 to -13 % (lawnmower), -2 to -4 %
  // (oblique), +-2 % (compressed); ATE within 0.001 m (compressed 0.149 -> 0.145 m); a window of
  // 8 or 10 saved little, 2 cost ATE (loop 0.042 -> 0.047 m) (docs/benchmarks.md). RunMapping
  // sets 0 for photo folders: each photo is a keyframe overlapping only its neighbours, and
  // there the window drifted (Brighton Beach 0.58 -> 0.81 m).
  // 0 = the whole submap every time (the paper).
  int local_ba_keyframes = 6;

  // Memory bound: a submap that reaches this many frames is completed regardless of its
  // keyframe count (keeps per-frame feature storage bounded on a hovering drone).
  int max_frames_per_submap = 1500;

  // --- focal length (only when bundle_adjustment.refine_focal) ---
  // Landmarks triangulated while the focal was far from the truth stay where that focal put
  // them: bundle adjustment then settles in a bent solution although the focal itself ends
  // right (measured on a 640x360 oblique loop at 100 m started 10 % long: trajectory error
  // 25 m; tracked again at the settled focal: 0.13 m). So when a submap reaches its last
  // keyframe (or the input ends) and the running focal estimate has moved by more than this
  // fraction since the submap started, its frames (features kept in memory) are tracked again
  // from its first frame at the new focal, and it completes after that. Checked at completion,
  // not at every keyframe: a few keyframes give a noisy estimate. 0 = never (the paper).
  double rebuild_focal_change = 0.02;
  // At most this many rebuilds per submap (the estimate usually settles after one).
  int max_submap_rebuilds = 2;
  // With the focal held fixed (bundle_adjustment.refine_focal off: calibrated intrinsics), the
  // first completed submap is bundle adjusted on a copy, to convergence with the focal fixed and
  // then once more with it free and no prior; SubmapBuilderStats::free_focal_px reports where it
  // went, and the job warns when that is far from the given focal. Why: a focal from EXIF or a
  // data sheet passed as a calibration is held wrong for the whole run (Brighton Beach photos:
  // EXIF 739.6 px, this check 845.6 px, COLMAP 884 px; fixed 0.59 m error, refined 0.46 m).
  // Measured: the true focal moves 0.0 / 0.0 / +0.5 % on the lawnmower / loop / oblique
  // benchmark videos and -1.1 to +0.1 % on the six focal_range clips; a focal 10 % short or
  // 15 % long comes back to within 3.3 % of the truth. Costs two bundle adjustments, once
  // (0.1-0.5 s at 640x360).
  bool check_fixed_focal = true;
  // Nadir footage of flat ground hardly constrains the focal length: a longer focal and a
  // higher camera explain the images almost equally well (translation over a plane moves
  // every pixel by focal x speed / height, so only attitude changes and relief tell them
  // apart), and the free focal wanders where the prior and the bootstrap push it (measured
  // from the 0.8 x long-side guess: a flat field at 100 m went to +31 %, the loop benchmark
  // video at 40 m to -28 %, both with the map's heights as far off). So the first submap to
  // reach its last keyframe (or the end of input) is bundle adjusted three more times on a
  // copy, with the focal fixed at its estimate and at (1 -/+ focal_profile_step) times it. If
  // either side raises the reprojection rms by less than focal_profile_min_rms_increase
  // (relative), the images do not single the estimate out: the focal returns to its initial
  // value (the guess, or glam map --focal) and stays fixed for the rest of the run, the
  // submap is tracked again at it, and the report warns. Measured at 10 %: oblique clips
  // +9 % and more, nadir clips with relief +0.05 to +0.6 % (estimates within 2 % of the
  // truth), the two failures -0.05 % and -0.03 % (the estimate sat on a slope, held there by
  // the prior). Three bundle adjustments, once (0.2-1 s at 640x360). 0 = off (the paper).
  double focal_profile_step = 0.1;
  double focal_profile_min_rms_increase = 0.0002;
  // Radial distortion (only when bundle_adjustment.refine_k1), like the focal profile: the
  // first submap to reach its last keyframe (or the end of input) is bundle adjusted twice
  // more on a copy, with k1 fixed at its estimate and at its initial value (0 unless given).
  // If the initial value raises the reprojection rms by less than this fraction, the images
  // do not ask for the estimate: k1 returns to the initial value and stays fixed, and the
  // submap is tracked again (once for both decisions: the focal profile is taken on the same
  // pass, at the k1 just decided and, when k1 is held, around the focal a copy adjusted at
  // the held k1 gives). Why: estimated throughout, k1 came out -0.045 to +0.011 on
  // distortion-free synthetic lenses and bent their maps (ATE up to 3x; a clip at 60 deg
  // pitch lost its submaps' connection), while a k1 = -0.15 lens mapped as pinhole is 25x
  // worse than with k1 estimated. 0 = k1 estimated throughout.
  double k1_profile_min_rms_increase = 0.003;
  // Rolling-shutter readout estimated on the first submap (frames carry
  // CompactFeatures::rolling_shutter_rates; `glam map --rolling-shutter-ms auto`): when it
  // completes, its keyframes are bundle adjusted on a copy with their observations corrected
  // for readouts 0, step, 2 step, ... up to readout_max_ms (0, 15, 30, 45, 60 ms), and the readout with the lowest
  // reprojection rms (refined by a parabola through its neighbours) is taken if it fits at
  // least readout_min_rms_gain (relative) better than none; the submap is then tracked again
  // with its frames corrected. Why by the rms: a wrong readout, too short or too long, leaves
  // each frame squashed or stretched along the motion, which no pinhole pose explains
  // (measured on a 30 ms clip: rms 0.43 / 0.34 / 0.31 / 0.305 / 0.33 px at 0 / 15 / 25 / 30 /
  // 40 ms; on a global-shutter clip 0.31 px at 0, 0.34 px at 15 ms). A submap flown straight at
  // constant speed cannot tell (every frame is squashed alike, as if the ground were): when its
  // profile gains less, the next submap is profiled, up to readout_max_submaps; the submaps
  // completed before the decision stay uncorrected.
  bool estimate_readout = false;
  int readout_max_submaps = 3;
  double readout_max_ms = 60.0;
  double readout_step_ms = 15.0;
  double readout_min_rms_gain = 0.02;
  // The focal prior's weight (bundle_adjustment.focal_prior_weight) is multiplied by
  // 1 + focal_prior_growth * (keyframes of completed submaps): what earlier submaps agreed on
  // is evidence a new submap should not overturn alone. Without it a short, weakly
  // conditioned submap (measured: 4 keyframes at the end of a clip) moves the shared focal
  // 16 % and maps its frames 3.7 m wrong. The first submap keeps the paper's weak prior;
  // 0 = the weak prior throughout (the paper; lets the estimate follow a zoom).
  double focal_prior_growth = 1.0;

  // --- completion ---
  // Before the final relocalisation, up to this many tracked (non-key) frames of the submap
  // join one last bundle adjustment with their PnP inlier matches as observations (focal
  // lengths fixed). Keyframes alone leave most landmarks seen from two or three views far
  // apart in time; the tracked frames in between add the views a batch reconstruction would
  // have. 0 = the paper's completion (PnP relocalisation only). Frames are picked evenly
  // over the submap, detection frames first.
  int completion_ba_max_frames = 20;
  // After the final relocalisation, camera centres are smoothed over time and rotations
  // re-solved (centre_smoothing.h: compressed video makes nadir poses jump sideways).
  // half_window_s = 0: the paper's per-frame PnP poses.
  CentreSmoothingOptions centre_smoothing;

  // --- end of input ---
  // The submap open when the input ends has fewer keyframes than the others and, started at
  // the previous submap's last 10 %, a short baseline: measured on the 300-frame lawnmower
  // clip with 6 keyframes per submap, 4 keyframes and a map median error of 1.1-1.3 m against
  // 0.1-0.5 m for the full submaps. With this on, such a submap is tracked again from the
  // previous submap's middle keyframe (those frames are kept in memory), so it gets about
  // half a submap more of baseline and views. Off = the paper's behaviour.
  bool extend_short_final_submap = true;
  // "Short" means fewer keyframes than this fraction of keyframes_per_submap. The extension
  // adds about half a submap, so at 0.75 an extended submap stays within ~1.25 regular ones;
  // a nearly full final submap is better left as it is: on the oblique benchmark video a
  // 16-of-20-keyframe final submap extended to 26 keyframes over 426 frames of a turning
  // flight bent (ATE of its frames 0.148 m against 0.076 m unextended; the whole video
  // 0.213 -> 0.178 m). 1 = extend every final submap below keyframes_per_submap.
  double short_final_submap_fraction = 0.75;

  BundleAdjustmentOptions bundle_adjustment;
  OutlierFilterOptions outlier_filter;

  void Check() const;

  // Thresholds for a submap whose first keyframe has `features` features.
  int EffectiveTauResection(int features) const;
  int EffectiveTauStereo(int features) const;
};

}  // namespace glam
