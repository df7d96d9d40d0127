// Carries the SIFT features of one *detection* frame into the frames that follow it with
// pyramidal Lucas-Kanade optical flow (cv::calcOpticalFlowPyrLK), so that SIFT — the most
// expensive step of mapping (~270 ms per 720p frame on one core) — runs on every N-th frame
// only, while every frame still gets features for tracking.
//
// A propagated frame's features are the detection frame's keypoints that KLT found again, at
// their new positions, each with the detection frame's descriptor and colour. The submap
// builder therefore needs no second code path: its descriptor matching simply finds the same
// descriptor again (its keypoint moved), and triangulation between a detection frame and a
// propagated frame pairs exactly the keypoints that KLT followed.
//
// Every frame is tracked from the detection frame itself (not from the previous frame), with
// the previous frame's result as the initial guess: positions do not accumulate drift along
// the chain, and a point lost once is not picked up again by a neighbour's patch.
#pragma once

#include <cstddef>
#include <vector>

#include <opencv2/core.hpp>

#include "engine/features/features.h"

namespace glam {

struct KltOptions {
  // Lucas-Kanade window (pixels, odd) and pyramid levels above the base. Every frame starts
  // from the previous frame's positions, so the pyramid only has to bridge one frame of motion:
  // 11 x 11 with 3 levels reaches ~40 px. 11 instead of 13 (2026-12-03): KLT ~30 % cheaper
  // (640x360, one core: 16.7 vs 24.4 ms per frame), positions 0.06 px apart, and on the 29 runs of
  // bench/focal_range.sh every focal start still converged with ATE equal or better (seed 3
  // from +100 %: 0.198 vs 1.05 m); benchmark videos 0.090 / 0.067 / 0.197 m against
  // 0.094 / 0.066 / 0.178 m (docs/benchmarks.md). Earlier, 15 -> 13 gave 1280x720 lawnmower
  // 13.4 -> 18.8 fps at the same accuracy.
  int window_px = 11;
  int pyramid_levels = 3;
  // Iterations stop when a step is below epsilon_px. 0.1 px instead of 0.03: positions move
  // by 0.005-0.01 px on average (SIFT locates keypoints to ~0.1-0.3 px), KLT takes ~15 % less
  // time and the benchmark videos map the same to the millimetre (ATE 0.094 / 0.066 / 0.178
  // m against 0.093 / 0.066 / 0.178 m) 8-12 % faster (docs/benchmarks.md).
  int max_iterations = 20;
  double epsilon_px = 0.1;
  // Track rejected when the mean absolute intensity difference of the matched windows (grey
  // levels, 0-255) exceeds this. Only a coarse guard: the error of a wrong track depends on the
  // image's contrast (on smooth low-contrast ground a wrong window differs by < 10 grey levels).
  double max_patch_error = 30.0;
  // Minimum eigenvalue of the window's spatial gradient matrix (OpenCV's minEigThreshold,
  // normalised by the window area): textureless windows cannot be located.
  double min_eigen_value = 1e-4;
  // Tracked positions closer than this to the image border are dropped (the window would
  // leave the image).
  double border_px = 2.0;
  // Wrong-track tests (either, both or none). Where a texture replaced the tracked ground, 600
  // of 800 tracks passed the patch-error test above alone.
  //  * Forward-backward (default): every point is tracked back to the detection frame and
  //    dropped if it does not return within this distance (pixels; correct tracks return to
  //    ~0.05 px; 22 of the 800 above passed at 0.5 px, 44 at 1 px). 0 = off. It doubles the
  //    cost of KLT (640x360, ~1800 points, one core: 27 ms per frame against 18 ms with the
  //    correlation test instead; glam_bench_feature_stage).
  //  * Patch correlation: the normalised cross-correlation of the track's window in the
  //    detection frame and in this frame (finest level, bilinear) must reach this; ~2 us per
  //    point. At 0.9 it rejects as many wrong tracks on the replaced-texture test (0.8 lets
  //    three times as many through: smooth texture correlates well once LK aligned it) and
  //    leaves calibrated runs as accurate (docs/benchmarks.md), but it was tried as the default
  //    and dropped: it also drops the tracks whose window deforms most under perspective, at
  //    the image edges of oblique views, which are the rays that pin the focal length, and
  //    uncalibrated runs converged less often (bench/focal_range.sh: 17 of 23 starts within
  //    1 % against 19 of 23; a clip that converged from +10 % ended 3 % off). -1 = off.
  double max_forward_backward_px = 0.5;
  double min_patch_correlation = -1;
  // Used by the feature stage (DecoderWorker): when fewer than this fraction of the detection
  // frame's keypoints are still tracked (fast motion, a cut, ground leaving the view), the
  // frame gets SIFT itself and becomes the new reference instead of waiting for the next
  // scheduled detection.
  double min_survival_fraction = 0.5;

  void Check() const;  // throws InputError
};

class KltPropagator {
 public:
  explicit KltPropagator(const KltOptions& options = {});

  // Makes `features`, detected on `gray` (8-bit, one channel), the reference that later
  // frames are tracked from.
  void SetReference(const cv::Mat& gray, const Features& features);

  // Features of `gray` (the next frame, same size as the reference): the reference keypoints
  // KLT still finds, with Features::detected = false. Points once lost stay lost until the next
  // SetReference.
  Features Propagate(const cv::Mat& gray);

  bool has_reference() const { return !reference_pyramid_.empty(); }
  std::size_t reference_size() const { return reference_.size(); }
  // How far the image moved since the reference, for the feature stage's adaptive schedule:
  // the median distance (pixels) of the still tracked keypoints from their reference
  // positions in the last propagated frame, and the frames propagated since SetReference.
  // Both 0 right after SetReference; the distance is 0 when nothing is tracked. Computed when
  // asked (O(tracked points)), so the fixed schedule pays nothing for it.
  double median_displacement_px() const;
  int frames_since_reference() const { return frames_since_reference_; }

 private:
  KltOptions options_;
  cv::Size window_;
  std::vector<cv::Mat> reference_pyramid_;  // level 0 (index 0) is the reference image
  Features reference_;
  std::vector<int> alive_;                 // reference indices still tracked
  std::vector<cv::Point2f> last_position_;  // their positions in the last propagated frame
  int frames_since_reference_ = 0;
};

}  // namespace glam
