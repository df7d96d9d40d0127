// A stand-in for RunMapping in the job-service and HTTP tests: it reports progress the way the
// engine does (frames, submaps, revisions and previews of the open submap growing step by step), can be held at one step until
// the test releases or cancels it, and writes a trajectory.tum, in milliseconds and without a
// video. Holding is what lets tests cancel, restart and run jobs side by side deterministically.
#pragma once

#include <atomic>
#include <chrono>
#include <filesystem>
#include <string>

#include "engine/core/cancellation.h"
#include "engine/pipeline/progress.h"

namespace glam::testing {

struct FakeMapping {
  int steps = 10;
  std::int64_t frames_per_step = 10;
  int steps_per_submap = 3;  // submaps_completed and revision = step / steps_per_submap
  int hold_step = 5;         // where `hold` stops the run
  std::chrono::milliseconds step_pause{2};
  std::string trajectory = "0 0 0 0 0 0 0 1\n";

  std::atomic<bool> hold{false};     // set by the test: stop at hold_step until cleared or cancelled
  std::atomic<bool> at_hold{false};  // set by the run once it waits there

  // Throws Cancelled when `cancel` fires (also while held).
  void Run(const std::filesystem::path& dir, const ProgressCallback& progress, const CancellationToken& cancel);
};

}  // namespace glam::testing
