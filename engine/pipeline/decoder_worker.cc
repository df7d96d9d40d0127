#include "engine/pipeline/decoder_worker.h"

#include <chrono>
#include <optional>
#include <thread>

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
  // Separate extractors (not copies sharing one cv::SIFT) so workers share no state.
  for (int i = 0; i < options_.workers; ++i) extractors_.emplace_back(options_.sift);
}

void DecoderWorker::Run() {
  try {
    if (options_.detection_interval == 1) {
      RunDetectEveryFrame();
    } else {
      RunWithPropagation();
    }
  } catch (...) {
    error_ = std::current_exception();
  }
  queue_.Close();
}

bool DecoderWorker::Emit(FrameFeatures item) {
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
    while (batch.size() < extractors_.size()) {
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

// One step: the reference (a detection frame) has been emitted; read the next N frames, start
// SIFT on the last of them (the next detection frame) on a helper thread, propagate the others
// from the reference meanwhile, then emit the detection frame and make it the reference.
void DecoderWorker::RunWithPropagation() {
  const auto first_start = Clock::now();
  std::optional<Frame> first = source_.Next();
  if (!first) return;
  FrameFeatures reference = Detect(*first, 0);
  klt_.SetReference(ToGray(first->bgr), reference.features);
  busy_seconds_ += Seconds(first_start);
  if (!Emit(std::move(reference))) return;

  const auto interval = static_cast<std::size_t>(options_.detection_interval);
  while (!ShouldStop()) {
    auto start = Clock::now();
    std::vector<Frame> frames;
    while (frames.size() < interval) {
      std::optional<Frame> frame = source_.Next();
      if (!frame) break;
      frames.push_back(std::move(*frame));
    }
    if (frames.empty()) return;
    // At the end of input the last frame is propagated like the others (no detection frame).
    const bool detect_last = frames.size() == interval;
    const std::size_t propagated = detect_last ? frames.size() - 1 : frames.size();

    std::optional<FrameFeatures> detection;
    std::exception_ptr detection_error;
    std::thread helper;
    auto detect_last_frame = [&] {
      NameCurrentThread("glam-sift");
      try {
        detection = Detect(frames.back(), extractors_.size() > 1 ? 1 : 0);
      } catch (...) {
        detection_error = std::current_exception();
      }
    };
    if (detect_last && extractors_.size() > 1) helper = std::thread(detect_last_frame);
    // Propagated frames are handed on as they are made, so the builder works on them while the
    // helper still extracts SIFT.
    bool open = true;
    std::exception_ptr propagation_error;
    try {
      for (std::size_t i = 0; i < propagated && open; ++i) {
        const cv::Mat gray = ToGray(frames[i].bgr);
        FrameFeatures item{frames[i].index, frames[i].timestamp_s, klt_.Propagate(gray)};
        const double survival = static_cast<double>(item.features.size()) /
                                static_cast<double>(std::max<std::size_t>(1, klt_.reference_size()));
        if (survival < options_.klt.min_survival_fraction) {
          // Most of the reference is gone: detect here and follow this frame instead.
          item = Detect(frames[i], 0);
          klt_.SetReference(gray, item.features);
        }
        busy_seconds_ += Seconds(start);
        open = Emit(std::move(item));
        start = Clock::now();
      }
    } catch (...) {
      propagation_error = std::current_exception();
    }
    if (helper.joinable()) helper.join();
    if (propagation_error) std::rethrow_exception(propagation_error);
    if (!open) return;
    if (detect_last && extractors_.size() == 1 && !detection_error) detect_last_frame();
    if (detection_error) std::rethrow_exception(detection_error);
    if (detection) klt_.SetReference(ToGray(frames.back().bgr), detection->features);
    busy_seconds_ += Seconds(start);
    if (detection && !Emit(std::move(*detection))) return;
    if (!detect_last) return;
  }
}

}  // namespace glam
