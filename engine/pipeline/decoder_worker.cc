#include "engine/pipeline/decoder_worker.h"

#include <chrono>
#include <thread>

namespace glam {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

}  // namespace

DecoderWorker::DecoderWorker(FrameSource& source, const SiftOptions& sift, int workers,
                             BoundedQueue<FrameFeatures>& queue, CancellationToken cancel,
                             const std::atomic<bool>& stop, std::size_t min_features)
    : source_(source),
      queue_(queue),
      cancel_(std::move(cancel)),
      stop_(stop),
      min_features_(min_features) {
  // Separate extractors (not copies sharing one cv::SIFT) so workers share no state.
  for (int i = 0; i < workers; ++i) extractors_.emplace_back(sift);
}

void DecoderWorker::Run() {
  try {
    bool more = true;
    while (more && !cancel_.IsCancelled() && !stop_.load()) {
      const auto start = Clock::now();
      std::vector<Frame> batch;
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
        ++frames_;
        if (item.features.size() < min_features_) ++frames_without_features_;
        if (!queue_.Push(std::move(item))) {  // consumer closed the queue
          more = false;
          break;
        }
      }
    }
  } catch (...) {
    error_ = std::current_exception();
  }
  queue_.Close();
}

// Frame i goes to extractor i; all but the first on helper threads. Joins every thread
// before rethrowing the first error, so no thread outlives a failure.
std::vector<FrameFeatures> DecoderWorker::ExtractBatch(const std::vector<Frame>& batch) {
  std::vector<FrameFeatures> items(batch.size());
  std::vector<std::exception_ptr> errors(batch.size());
  auto extract = [&](std::size_t i) {
    try {
      items[i] = {batch[i].index, batch[i].timestamp_s, extractors_[i].Extract(batch[i].bgr)};
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

}  // namespace glam
