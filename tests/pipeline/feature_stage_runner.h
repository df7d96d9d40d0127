// Runs the feature stage (DecoderWorker) on a source to the end and returns what it emitted,
// in order; rethrows the stage's error. Shared by the feature-stage tests.
#pragma once

#include <atomic>
#include <optional>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "engine/pipeline/decoder_worker.h"

namespace glam::testing {

inline std::vector<FrameFeatures> RunFeatureStage(FrameSource& source, const FeatureStageOptions& options) {
  BoundedQueue<FrameFeatures> queue(4);
  std::atomic<bool> stop{false};
  DecoderWorker worker(source, options, queue, {}, stop);
  std::thread t([&] { worker.Run(); });
  std::vector<FrameFeatures> items;
  while (std::optional<FrameFeatures> item = queue.Pop()) items.push_back(std::move(*item));
  t.join();
  if (worker.error()) std::rethrow_exception(worker.error());
  EXPECT_EQ(worker.frames(), static_cast<std::int64_t>(items.size()));
  return items;
}

}  // namespace glam::testing
