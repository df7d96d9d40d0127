// `glam synth`: renders a synthetic aerial clip with exact ground truth into options.out:
// video.mp4, gt_trajectory.tum, intrinsics.json, gt_surface.json, gt_heights.f32, synth.json
// (the options, plus water_share_seen when the world has water)
// (and frames/NNNNNN.png with write_frames). A directory that already holds a complete clip
// made with identical options is left as it is (unless options.force), so CTest fixtures
// and benchmarks can call this freely.
#pragma once

#include "tools/synth/synth_options.h"

namespace glam::synth {

struct SynthReport {
  bool skipped = false;       // output was already up to date
  double world_seconds = 0;   // wall time to build the world
  double render_seconds = 0;  // wall time to render and encode all frames
  double water_share_seen = 0;  // mean fraction of the pixels showing open water
};

// Throws InputError for bad options, EnvironmentError for I/O or encoder failures.
SynthReport RunSynth(const SynthOptions& options);

}  // namespace glam::synth
