// Rolling-shutter correction of keypoint positions (added to the paper; docs/algorithm.md).
//
// Why: most drone cameras record video with a rolling shutter: the sensor is read out row by
// row, the top row some 10-40 ms before the bottom one, while the drone moves and turns. Each
// row then sees the ground from a slightly different pose, and no single pinhole pose explains
// the whole frame. The error is small per pixel (a 640x360 nadir view at 100 m, 10 m/s, 30 ms
// readout: the image is squashed by 0.5 % along the flight, < 1 px at the edges) but
// systematic, and looking down a sideways shift and a tilt move the image almost alike, so the
// per-frame poses slide along that ambiguity: measured on such a clip (calibrated) ATE 0.06 ->
// 0.58 m and map median 0.12 -> 1.97 m against the same flight with a global shutter.
//
// How: a keypoint seen in image row y was exposed at t + dt(y), dt(y) = readout * (y / (H - 1)
// - 0.5), so the frame's time t is that of its middle row. Over a few milliseconds the image
// motion is linear in time, so the position the point would have had at t is
//     p_mid = p - dt(y) * v(p),
// with v its image velocity (pixels per second). The velocity comes from the point's own track:
// KLT follows each detection frame's keypoints through the frames after it, so a keypoint's
// positions in the previous and next frame of the same track give v by finite differences
// (their mean when both exist). That needs no depth and no pose, and it holds for rotation,
// translation and relief alike. Keypoints without a track neighbour (new SIFT points that KLT
// lost at once) take v from a smooth model of the frame's flow: a quadratic in the image
// coordinates per component, fitted robustly to the measured velocities (the previous frame's
// model when too few were measured). This needs one frame of look-ahead, so each frame leaves
// the corrector when the next one arrives.
//
// Identity across frames: cv::KeyPoint::class_id is the keypoint's index in its detection
// frame (SiftExtractor sets it, KltPropagator keeps it), and a frame that was not detected
// shares its detection frame with the frame before it.
//
// The readout time is the camera's (a property of sensor and video mode): given (`glam map
// --rolling-shutter-ms MS`), or estimated (`auto`, the default of `glam map` and of jobs): the
// stage then hands keypoints on uncorrected with their motion per second of readout
// (Features::rolling_shutter_rates), and the submap builder picks the readout whose
// correction best fits the first submaps (SubmapOptions::estimate_readout). Without KLT
// tracks (SIFT on every frame, photo folders) nothing is corrected or estimated.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "engine/pipeline/frame_features.h"

namespace glam {

struct RollingShutterOptions {
  // Readout time from the first (top) image row to the last (ms); 0 = global shutter, no
  // correction. At most 100 ms (longer than a frame interval at 10 fps).
  double readout_ms = 0.0;
  // Estimate the readout instead (`--rolling-shutter-ms auto`): keypoints are handed on
  // uncorrected with their Features::rolling_shutter_rates, and the submap builder picks the
  // readout whose correction best fits the first submap (SubmapOptions::estimate_readout).
  bool estimate = false;
  // Velocities measured over a longer time than this (s) are not used (gaps, strided input).
  double max_frame_gap_s = 0.25;
  // A frame's flow model needs at least this many measured velocities.
  int min_model_points = 12;

  bool enabled() const { return readout_ms > 0 || estimate; }
  void Check() const;  // throws InputError
};

// "auto" (estimate) or a readout in milliseconds ("0" = global shutter); InputError otherwise.
RollingShutterOptions RollingShutterFromText(const std::string& text);
// Options that ask for the readout's estimate (MappingOptions' default).
RollingShutterOptions EstimatedRollingShutter();

// Image velocity field of one frame: v(x, y) = quadratic in normalised image coordinates,
// per component (pixels per second).
class FlowModel {
 public:
  // Robust least squares (two rounds, the second without points beyond 3 median residuals);
  // false when there are too few points.
  bool Fit(const std::vector<cv::Point2f>& points, const std::vector<cv::Point2f>& velocities,
           cv::Size image_size, int min_points);
  bool valid() const { return valid_; }
  cv::Point2f At(cv::Point2f p) const;
  // Residual beyond which a measured velocity is taken as wrong (pixels per second).
  double outlier_threshold() const { return outlier_threshold_; }

 private:
  std::array<double, 6> Basis(cv::Point2f p) const;
  bool valid_ = false;
  cv::Point2f centre_;
  double scale_ = 1.0;
  std::array<double, 6> vx_{}, vy_{};
  double outlier_threshold_ = 0.0;
};

class RollingShutterCorrector {
 public:
  RollingShutterCorrector(const RollingShutterOptions& options, cv::Size image_size);

  // Takes the next frame in input order, with raw keypoint positions; returns the frame before
  // it, corrected (nothing for the first frame).
  std::optional<FrameFeatures> Push(FrameFeatures next);
  // At the end of input: the last frame, corrected with what is known.
  std::optional<FrameFeatures> Flush();

  // Mean and largest correction applied so far (pixels), for the log.
  double mean_shift_px() const { return corrected_ > 0 ? shift_sum_ / corrected_ : 0.0; }
  double max_shift_px() const { return shift_max_; }

 private:
  // Raw positions of a frame's keypoints by class_id (NaN where absent).
  struct Track {
    double timestamp_s = 0;
    bool detected = true;
    std::vector<cv::Point2f> by_id;
  };
  static Track TrackOf(const FrameFeatures& frame);
  void Correct(FrameFeatures& frame, const Track* next);

  RollingShutterOptions options_;
  cv::Size image_size_;
  std::optional<Track> previous_;       // raw positions of the frame before pending_
  std::optional<FrameFeatures> pending_;
  std::optional<Track> pending_track_;  // raw positions of pending_, taken when it arrived
  FlowModel last_model_;
  double shift_sum_ = 0, shift_max_ = 0;
  long long corrected_ = 0;
};

}  // namespace glam
