// The decoder side of a mapping run (docs/architecture.md, data flow): decodes frames and
// extracts their SIFT features on its own thread(s), pushing them in input order into the
// bounded queue thread 1 consumes. SIFT on every frame is the throughput bottleneck, so
// frames are decoded in batches of `workers` and extracted in parallel.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <vector>

#include "engine/core/bounded_queue.h"
#include "engine/core/cancellation.h"
#include "engine/features/features.h"
#include "engine/features/sift_extractor.h"
#include "engine/video/frame_source.h"

namespace glam {

struct FrameFeatures {
  std::int64_t index = 0;
  double timestamp_s = 0;
  Features features;
};

class DecoderWorker {
 public:
  DecoderWorker(FrameSource& source, const SiftOptions& sift, int workers,
                BoundedQueue<FrameFeatures>& queue, CancellationToken cancel,
                const std::atomic<bool>& stop, std::size_t min_features);

  // Runs until the input ends, `stop` is set, the token is cancelled or the queue is closed;
  // always closes the queue. Errors are kept for error(), not thrown.
  void Run();

  std::exception_ptr error() const { return error_; }
  double busy_seconds() const { return busy_seconds_; }
  std::int64_t frames() const { return frames_; }
  std::int64_t frames_without_features() const { return frames_without_features_; }

 private:
  std::vector<FrameFeatures> ExtractBatch(const std::vector<Frame>& batch);

  FrameSource& source_;
  std::vector<SiftExtractor> extractors_;
  BoundedQueue<FrameFeatures>& queue_;
  CancellationToken cancel_;
  const std::atomic<bool>& stop_;
  const std::size_t min_features_;
  std::exception_ptr error_;
  double busy_seconds_ = 0;
  std::int64_t frames_ = 0;
  std::int64_t frames_without_features_ = 0;
};

}  // namespace glam
