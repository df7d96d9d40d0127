// Runs thread 1 (SubmapBuilder) over a synthetic fixture video with the product's feature
// stage (DecoderWorker), as the pipeline does, and keeps the completed submaps for the
// accuracy tests. Shared by the tests that compare configurations on the same clip.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <vector>

#include "engine/core/camera.h"
#include "engine/features/sift_extractor.h"
#include "engine/map/submap.h"
#include "engine/submap/submap_builder.h"
#include "engine/submap/submap_options.h"

namespace glam::test_support {

struct ClipRun {
  std::vector<Submap> submaps;
  std::int64_t frames = 0;  // frames fed to the builder
  double focal = 0;         // the builder's final focal estimate
  SubmapBuilderStats stats;  // the builder's, after Finish()
};

// detection_interval: 0 = the product's automatic schedule, 1 = SIFT on every frame (paper).
// max_frames < 0: the whole video. sift: the feature stage's SIFT (the product's by default).
// skip_frame: frames for which it returns true never reach the feature stage or the builder,
// as a live stream drops them (their indices and times are missing from the sequence).
ClipRun RunSubmapBuilderOnClip(const std::filesystem::path& video, const Intrinsics& intrinsics,
                               const SubmapOptions& options, int detection_interval,
                               std::int64_t max_frames = -1, const SiftOptions& sift = SiftOptions(),
                               const std::function<bool(std::int64_t frame_index)>& skip_frame = {});

}  // namespace glam::test_support
