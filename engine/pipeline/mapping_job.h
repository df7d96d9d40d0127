// One offline mapping run: video or image folder in, submaps + whole-map files out. Two
// threads: a decoder thread (FrameSource -> SIFT) feeds a bounded queue; the calling thread
// runs the submap builder (thread 1 of the paper), persists every completed submap and
// chains it into the world frame. Cancellation is polled on both sides, queues are closed on
// every exit path and the decoder thread is always joined; the first exception of either side
// is rethrown after joining, so a failure never leaves a thread behind or hangs the other side.
//
// Outputs in out_dir: submaps/<id>/, trajectory.tum, points.ply, report.json, graph.json.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/core/cancellation.h"
#include "engine/pipeline/mapping_options.h"
#include "engine/pipeline/progress.h"

namespace glam {

struct MappingTimings {
  double decode_and_features_s = 0;  // decoder thread busy time (decode + SIFT)
  double builder_s = 0;              // submap builder time, including BA
  double bundle_adjust_s = 0;        // of which bundle adjustment
  double chaining_s = 0;             // linking + levelling
  double writing_s = 0;              // submaps and whole-map files
  double total_s = 0;
};

struct MappingReport {
  std::string input;
  std::int64_t frames_total = -1;  // expected after stride (container estimate)
  std::int64_t frames_decoded = 0;
  std::int64_t frames_posed = 0;
  std::int64_t frames_unposed = 0;  // decoded but absent from trajectory.tum
  // Frames with fewer SIFT features than tracking needs (SubmapOptions::min_tracking_inliers):
  // black, uniform, overexposed or badly blurred frames, which can never be posed.
  std::int64_t frames_without_features = 0;
  std::int64_t keyframes = 0;
  std::int64_t submaps = 0;
  std::int64_t submaps_discarded = 0;
  std::int64_t disconnected_submaps = 0;
  std::int64_t points = 0;
  std::int64_t tracking_losses = 0;
  double initial_focal = 0;  // processing pixels
  double focal = 0;          // estimate, processing pixels
  double focal_original = 0; // estimate, original-resolution pixels
  double fps = 0;            // input frame rate
  double processing_fps = 0; // frames decoded / total time
  int processing_width = 0;
  int processing_height = 0;
  bool input_ended_early = false;
  // Why frames or the whole input could not be mapped, in words for the user (also logged).
  // Bad footage (textureless, static, truncated) completes with these rather than failing:
  // the run did what the input allows, and the report says what is missing and why.
  std::vector<std::string> warnings;
  MappingTimings timings;

  nlohmann::json ToJson() const;
};

// Throws InputError (bad input/options, unwritable out_dir), EnvironmentError, Cancelled.
MappingReport RunMapping(const std::filesystem::path& input, const std::filesystem::path& out_dir,
                         const MappingOptions& options, const ProgressCallback& progress = {},
                         CancellationToken cancel = {});

}  // namespace glam
