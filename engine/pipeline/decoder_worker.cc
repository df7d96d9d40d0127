#include "engine/pipeline/decoder_worker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <limits>
#include <memory>
#include <optional>
#include <thread>

#include "engine/core/logging.h"
#include "engine/core/options.h"
#include "engine/core/thread_name.h"
#include "engine/features/gray_image.h"

namespace glam {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

}  // namespace

void FeatureStageOptions::Check() const {
  sift.Check();
  klt.Check();
  CheckInRange("FeatureStageOptions.workers", workers, 1, 16);
  CheckInRange("FeatureStageOptions.detection_interval", detection_interval, 1, 1000);
  if (max_detection_interval != 0) {
    CheckInRange("FeatureStageOptions.max_detection_interval", max_detection_interval, detection_interval, 1000);
  }
  CheckInRange("FeatureStageOptions.detection_motion_fraction", detection_motion_fraction, 0.001, 1.0);
  rolling_shutter.Check();
}

DecoderWorker::DecoderWorker(FrameSource& source, const FeatureStageOptions& options,
                             BoundedQueue<FrameFeatures>& queue, CancellationToken cancel,
                             const std::atomic<bool>& stop)
    : source_(source),
      options_(options),
      klt_(options.klt),
      queue_(queue),
      cancel_(std::move(cancel)),
      stop_(stop) {
  options_.Check();
  // Separate extractors (not copies sharing one cv::SIFT) so workers share no state. With
  // propagation, extractor 0 stays with this thread and each helper has one of its own.
  const int extractors =
      options_.detection_interval > 1 && options_.workers > 1 ? options_.workers + 1 : options_.workers;
  for (int i = 0; i < extractors; ++i) extractors_.emplace_back(options_.sift);
  const cv::Size size = source_.info().processing_size;
  target_motion_px_ = options_.detection_motion_fraction * std::hypot(size.width, size.height);
  if (options_.rolling_shutter.enabled()) {
    if (options_.detection_interval > 1) {
      rolling_shutter_.emplace(options_.rolling_shutter, source_.info().processing_size);
    } else {
      GLAM_LOG_WARN("rolling shutter: not corrected when SIFT runs on every frame (no KLT tracks to "
                    "measure the image motion)");
    }
  }
}

void DecoderWorker::Run() {
  try {
    if (options_.detection_interval == 1) {
      RunDetectEveryFrame();
    } else {
      RunWithPropagation();
    }
    if (rolling_shutter_ && !ShouldStop()) {
      if (std::optional<FrameFeatures> last = rolling_shutter_->Flush()) Forward(std::move(*last));
      if (!options_.rolling_shutter.estimate) {
        GLAM_LOG_INFO("rolling shutter ({} ms readout): keypoints moved {:.2f} px on average, {:.1f} px at most",
                      options_.rolling_shutter.readout_ms, rolling_shutter_->mean_shift_px(),
                      rolling_shutter_->max_shift_px());
      }
    }
  } catch (...) {
    error_ = std::current_exception();
  }
  queue_.Close();
}

bool DecoderWorker::Emit(FrameFeatures item) {
  if (!rolling_shutter_) return Forward(std::move(item));
  std::optional<FrameFeatures> ready = rolling_shutter_->Push(std::move(item));
  return !ready || Forward(std::move(*ready));
}

bool DecoderWorker::Forward(FrameFeatures item) {
  ++frames_;
  if (item.features.detected) ++frames_detected_;
  if (item.features.size() < options_.min_features) ++frames_without_features_;
  return queue_.Push(std::move(item));  // false: the consumer closed the queue
}

FrameFeatures DecoderWorker::Detect(const Frame& frame, std::size_t extractor) const {
  return {frame.index, frame.timestamp_s, extractors_[extractor].Extract(frame.bgr)};
}

void DecoderWorker::RunDetectEveryFrame() {
  while (!ShouldStop()) {
    const auto start = Clock::now();
    std::vector<Frame> batch;
    bool more = true;
    while (batch.size() < static_cast<std::size_t>(options_.workers)) {
      std::optional<Frame> frame = source_.Next();
      if (!frame) {
        more = false;
        break;
      }
      batch.push_back(std::move(*frame));
    }
    std::vector<FrameFeatures> items = ExtractBatch(batch);
    busy_seconds_ += Seconds(start);
    for (FrameFeatures& item : items) {
      if (!Emit(std::move(item))) return;
    }
    if (!more) return;
  }
}

// Frame i goes to extractor i; all but the first on helper threads. Joins every thread
// before rethrowing the first error, so no thread outlives a failure.
std::vector<FrameFeatures> DecoderWorker::ExtractBatch(const std::vector<Frame>& batch) {
  std::vector<FrameFeatures> items(batch.size());
  std::vector<std::exception_ptr> errors(batch.size());
  auto extract = [&](std::size_t i) {
    if (i > 0) NameCurrentThread("glam-sift");
    try {
      items[i] = Detect(batch[i], i);
    } catch (...) {
      errors[i] = std::current_exception();
    }
  };
  std::vector<std::thread> helpers;
  for (std::size_t i = 1; i < batch.size(); ++i) helpers.emplace_back(extract, i);
  if (!batch.empty()) extract(0);
  for (std::thread& t : helpers) t.join();
  for (const std::exception_ptr& e : errors) {
    if (e) std::rethrow_exception(e);
  }
  return items;
}

// Blocks of the propagation schedule: the frames after a detection frame up to and including
// the next detection frame (the block's last), whose SIFT runs on a helper thread while the
// frames before it are propagated. A block's length is fixed when it is read (every N-th
// frame, or planned from the motion of the block two back), so its detection never depends on
// the blocks still in flight and can start as soon as it is read.
struct DecoderWorker::DetectionBlock {
  std::vector<Frame> frames;
  bool detect_last = false;  // false at the end of input: every frame is propagated
  std::optional<FrameFeatures> detection;
  std::exception_ptr error;
  std::thread helper;
  // A block abandoned early (stop, error) still waits for its helper, which uses the frames.
  ~DetectionBlock() {
    if (helper.joinable()) helper.join();
  }
};

double DecoderWorker::MotionPerFrame() const {
  const int frames = klt_.frames_since_reference();
  if (frames == 0) return std::numeric_limits<double>::infinity();
  return klt_.median_displacement_px() / frames;
}

void DecoderWorker::RecordMotion(double pixels_per_frame) {
  recent_motion_.push_back(pixels_per_frame);
  if (recent_motion_.size() > 2) {
    recent_motion_.pop_front();
    ++first_recent_block_;
  }
}

double DecoderWorker::MeasuredMotion(std::size_t block) const {
  GLAM_CHECK(block >= first_recent_block_ && block - first_recent_block_ < recent_motion_.size(),
             "adaptive schedule planned from a block it has not measured");
  return recent_motion_[block - first_recent_block_];
}

std::size_t DecoderWorker::PlannedInterval(std::size_t block) const {
  const auto shortest = static_cast<std::size_t>(options_.detection_interval);
  if (!adaptive() || block < 2) return shortest;
  const double motion = MeasuredMotion(block - 2);
  const auto longest = static_cast<std::size_t>(options_.max_detection_interval);
  std::size_t planned = longest;  // a still image (or nothing tracked: the survival rule decides)
  if (motion > 0) {
    const double frames = std::floor(target_motion_px_ / motion);
    if (frames < static_cast<double>(longest)) planned = std::max(shortest, static_cast<std::size_t>(frames));
  }
  GLAM_LOG_DEBUG("feature stage: block {} planned with {} frames ({:.2f} px per frame two blocks back)", block,
                 planned, motion);
  return planned;
}

bool DecoderWorker::ReadAhead(std::deque<std::unique_ptr<DetectionBlock>>* blocks,
                              std::size_t* blocks_started) {
  const std::size_t helpers = extractors_.size() - 1;
  // Detection frames in flight: one per helper, bounded so that read-ahead keeps few frames;
  // the adaptive schedule plans from the block two back, so at most two.
  const auto longest =
      static_cast<std::size_t>(std::max(options_.detection_interval, options_.max_detection_interval));
  const std::size_t in_flight = adaptive() ? std::min<std::size_t>(helpers, 2) : helpers;
  const std::size_t max_blocks =
      helpers == 0 ? 1 : std::clamp<std::size_t>(kMaxReadAheadFrames / longest, 1, in_flight);
  while (blocks->size() < max_blocks) {
    const std::size_t interval = PlannedInterval(*blocks_started);
    auto block = std::make_unique<DetectionBlock>();
    while (block->frames.size() < interval) {
      std::optional<Frame> frame = source_.Next();
      if (!frame) break;
      block->frames.push_back(std::move(*frame));
    }
    if (block->frames.empty()) return false;
    block->detect_last = block->frames.size() == interval;
    if (block->detect_last && helpers > 0) {
      // Blocks finish in the order they start, so extractor 1 + (n mod helpers) is free again.
      const std::size_t extractor = 1 + *blocks_started % helpers;
      DetectionBlock* b = block.get();
      b->helper = std::thread([this, b, extractor] {
        NameCurrentThread("glam-sift");
        try {
          b->detection = Detect(b->frames.back(), extractor);
        } catch (...) {
          b->error = std::current_exception();
        }
      });
    }
    ++*blocks_started;
    const bool ended = !block->detect_last;
    blocks->push_back(std::move(block));
    if (ended) return false;
  }
  return true;
}

// The first frame is detected here while the helpers already extract the next detection
// frames; then block by block: propagate its frames from the reference (handed on as they are
// made, so the builder works on them meanwhile), wait for its detection, emit it and make it
// the reference, and read the next block so that its SIFT starts.
void DecoderWorker::RunWithPropagation() {
  auto start = Clock::now();
  std::optional<Frame> first = source_.Next();
  if (!first) return;
  std::deque<std::unique_ptr<DetectionBlock>> blocks;
  std::size_t blocks_started = 0;
  bool more = ReadAhead(&blocks, &blocks_started);
  FrameFeatures reference = Detect(*first, 0);
  klt_.SetReference(ToGray(first->bgr), reference.features);
  busy_seconds_ += Seconds(start);
  if (!Emit(std::move(reference))) return;

  while (!blocks.empty() && !ShouldStop()) {
    start = Clock::now();
    DetectionBlock& block = *blocks.front();
    const std::size_t propagated = block.detect_last ? block.frames.size() - 1 : block.frames.size();
    for (std::size_t i = 0; i < propagated; ++i) {
      const cv::Mat gray = ToGray(block.frames[i].bgr);
      FrameFeatures item{block.frames[i].index, block.frames[i].timestamp_s, klt_.Propagate(gray)};
      const double survival = static_cast<double>(item.features.size()) /
                              static_cast<double>(std::max<std::size_t>(1, klt_.reference_size()));
      // The adaptive plan came from older motion; where the image now moves faster than it
      // allowed for, do not wait longer than the fixed schedule would.
      const bool outran_plan = adaptive() && klt_.frames_since_reference() >= options_.detection_interval &&
                               klt_.median_displacement_px() > 2 * target_motion_px_;
      if (survival < options_.klt.min_survival_fraction || outran_plan) {
        // Most of the reference is gone (or moved too far): detect here and follow this frame.
        item = Detect(block.frames[i], 0);
        klt_.SetReference(gray, item.features);
      }
      if (i + 1 == propagated && adaptive()) RecordMotion(MotionPerFrame());
      busy_seconds_ += Seconds(start);
      if (!Emit(std::move(item))) return;
      start = Clock::now();
    }
    if (!block.detect_last) return;  // end of input
    if (block.helper.joinable()) block.helper.join();
    if (block.error) std::rethrow_exception(block.error);
    if (!block.detection) block.detection = Detect(block.frames.back(), 0);  // one worker
    klt_.SetReference(ToGray(block.frames.back().bgr), block.detection->features);
    FrameFeatures detection = std::move(*block.detection);
    blocks.pop_front();
    if (more) more = ReadAhead(&blocks, &blocks_started);
    busy_seconds_ += Seconds(start);
    if (!Emit(std::move(detection))) return;
  }
}

}  // namespace glam
