// The decoder side of a mapping run (docs/architecture.md, data flow): decodes frames and
// gives each its features on its own thread(s), pushing them in input order into the bounded
// queue thread 1 consumes.
//
// SIFT is the throughput bottleneck (~270 ms per 720p frame on one core). Two schedules:
//  * detection_interval = 1 (the paper): SIFT on every frame, `workers` frames extracted in
//    parallel.
//  * detection_interval = N > 1: SIFT on every N-th frame only; the frames in between get the
//    last detection frame's keypoints carried over by KLT (KltPropagator). SIFT of the next
//    `workers` detection frames runs on helper threads (the schedule is fixed, so they can
//    start as soon as their frames are read) while KLT fills in the frames before them. Why
//    more than one: at 1280x720 one detection costs ~320 ms against ~60 ms for the five
//    frames KLT fills in, so with one helper the stage ran on little more than one core
//    (docs/benchmarks.md). A frame whose KLT survivors fall below
//    KltOptions::min_survival_fraction gets SIFT at once (on this thread) and becomes the new
//    reference; the scheduled detections are unaffected, so the output does not depend on
//    the number of workers.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <exception>
#include <memory>
#include <optional>
#include <vector>

#include "engine/core/bounded_queue.h"
#include "engine/core/cancellation.h"
#include "engine/features/features.h"
#include "engine/features/klt_propagator.h"
#include "engine/features/sift_extractor.h"
#include "engine/pipeline/frame_features.h"
#include "engine/pipeline/rolling_shutter.h"
#include "engine/video/frame_source.h"

namespace glam {

struct FeatureStageOptions {
  SiftOptions sift;
  KltOptions klt;
  int workers = 2;             // threads extracting SIFT at the same time
  int detection_interval = 1;  // SIFT on every N-th frame, KLT in between (1 = every frame)
  // Adaptive schedule (when max_detection_interval > detection_interval > 1): each block's
  // interval is chosen between the two from the image motion KLT measured, so that the
  // tracked keypoints move by about detection_motion_fraction of the image diagonal (median)
  // between detections. Why: a survey flown high moves the image by a few pixels per frame,
  // so a fixed interval short enough for fast footage detects slow footage more often than
  // its tracks need; measured, it saved 29 % of the detections on the robustness clips and
  // 6-14 % of the wall time where it stretched, at +7.5 % in the sum of the calibrated ATEs
  // (docs/benchmarks.md, "Adaptive detection schedule"). The interval of block k is planned
  // from the motion measured over block k - 2 (the last one complete when block k is read
  // ahead with two detections in flight), so the output does not depend on the number of
  // workers; a block whose motion outruns the plan (twice the target after
  // detection_interval frames) is detected at once. 0 = detection_interval: the fixed
  // schedule (the product's default, for that accuracy: MappingOptions::max_detection_seconds).
  int max_detection_interval = 0;
  double detection_motion_fraction = 0.03;
  // Frames with fewer features than this are counted as featureless (report warning).
  std::size_t min_features = 0;
  // Keypoints corrected for the camera's rolling shutter (rolling_shutter.h) before they are
  // handed on; needs KLT tracks (detection_interval > 1), ignored without.
  RollingShutterOptions rolling_shutter;

  void Check() const;  // throws InputError
};

class DecoderWorker {
 public:
  // Frames read ahead for detections in flight are bounded by this (so a long detection
  // interval keeps one block, not `workers` blocks, of decoded frames in memory).
  static constexpr std::size_t kMaxReadAheadFrames = 64;

  DecoderWorker(FrameSource& source, const FeatureStageOptions& options,
                BoundedQueue<FrameFeatures>& queue, CancellationToken cancel,
                const std::atomic<bool>& stop);

  // Runs until the input ends, `stop` is set, the token is cancelled or the queue is closed;
  // always closes the queue. Errors are kept for error(), not thrown.
  void Run();

  std::exception_ptr error() const { return error_; }
  double busy_seconds() const { return busy_seconds_; }
  std::int64_t frames() const { return frames_; }
  std::int64_t frames_detected() const { return frames_detected_; }
  std::int64_t frames_without_features() const { return frames_without_features_; }
  // The rolling-shutter correction applied (0 without one): readout, mean and largest shift.
  double rolling_shutter_ms() const { return rolling_shutter_ ? options_.rolling_shutter.readout_ms : 0.0; }
  double rolling_shutter_mean_shift_px() const { return rolling_shutter_ ? rolling_shutter_->mean_shift_px() : 0.0; }
  double rolling_shutter_max_shift_px() const { return rolling_shutter_ ? rolling_shutter_->max_shift_px() : 0.0; }

 private:
  // Both return when the input ends, the consumer closed the queue or the run must stop.
  void RunDetectEveryFrame();
  void RunWithPropagation();
  struct DetectionBlock;
  // Reads blocks (and starts their detections) until as many are pending as helpers allow;
  // false once the input has ended.
  bool ReadAhead(std::deque<std::unique_ptr<DetectionBlock>>* blocks, std::size_t* blocks_started);
  std::vector<FrameFeatures> ExtractBatch(const std::vector<Frame>& batch);
  FrameFeatures Detect(const Frame& frame, std::size_t extractor) const;
  // Hands a frame on: through the rolling-shutter corrector (one frame later) when there is
  // one, then into the queue. False once the consumer closed the queue.
  bool Emit(FrameFeatures item);
  bool Forward(FrameFeatures item);
  bool ShouldStop() const { return cancel_.IsCancelled() || stop_.load(); }
  bool adaptive() const {
    return options_.detection_interval > 1 && options_.max_detection_interval > options_.detection_interval;
  }
  // Frames (the last one detected) of the block read as the `block`-th (counted from 0).
  std::size_t PlannedInterval(std::size_t block) const;
  // The motion measured over each processed block, of which the last two are kept.
  void RecordMotion(double pixels_per_frame);
  double MeasuredMotion(std::size_t block) const;
  // Image motion in pixels per frame at the end of a propagated stretch (KLT's median
  // displacement over the frames since the reference); infinity right after a detection.
  double MotionPerFrame() const;

  FrameSource& source_;
  FeatureStageOptions options_;
  std::vector<SiftExtractor> extractors_;
  KltPropagator klt_;
  std::optional<RollingShutterCorrector> rolling_shutter_;
  BoundedQueue<FrameFeatures>& queue_;
  CancellationToken cancel_;
  const std::atomic<bool>& stop_;
  std::exception_ptr error_;
  double busy_seconds_ = 0;
  std::int64_t frames_ = 0;
  std::int64_t frames_detected_ = 0;
  std::int64_t frames_without_features_ = 0;
  std::deque<double> recent_motion_;   // pixels per frame over the last processed blocks
  std::size_t first_recent_block_ = 0;  // the block recent_motion_.front() was measured on
  double target_motion_px_ = 0;         // detection_motion_fraction of the image diagonal
};

}  // namespace glam
