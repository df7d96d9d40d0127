#include "tests/support/fake_mapping.h"

#include <fstream>
#include <thread>

namespace glam::testing {

void FakeMapping::Run(const std::filesystem::path& dir, const ProgressCallback& progress,
                      const CancellationToken& cancel) {
  for (int i = 1; i <= steps; ++i) {
    cancel.ThrowIfCancelled();
    MappingProgress p;
    p.stage = "mapping";
    p.frames_done = i * frames_per_step;
    p.frames_total = steps * frames_per_step;
    p.submaps_completed = i / steps_per_submap;
    p.revision = i / steps_per_submap;
    // A preview of the open submap (the one after the completed ones) on every step.
    p.previews = i;
    p.preview_submap = p.submaps_completed;
    p.preview_keyframes = 2 + i % steps_per_submap;
    progress(p);
    while (hold && i == hold_step) {
      at_hold = true;
      cancel.ThrowIfCancelled();
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    std::this_thread::sleep_for(step_pause);
  }
  std::ofstream(dir / "trajectory.tum") << trajectory;
}

}  // namespace glam::testing
