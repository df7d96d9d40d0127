// One offline mapping run: video or image folder in, submaps + whole-map files out. Two
// threads: a decoder thread (FrameSource -> SIFT) feeds a bounded queue; the calling thread
// runs the submap builder (thread 1 of the paper), persists every completed submap and
// chains it into the world frame. Cancellation is polled on both sides, queues are closed on
// every exit path and the decoder thread is always joined; the first exception of either side
// is rethrown after joining, so a failure never leaves a thread behind or hangs the other side.
//
// Outputs in out_dir: submaps/<id>/, trajectory.tum, points.ply, report.json, graph.json,
// and trajectory.geojson when the map is georeferenced.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "engine/core/cancellation.h"
#include "engine/pipeline/mapping_options.h"
#include "engine/pipeline/mapping_report.h"
#include "engine/pipeline/progress.h"

namespace glam {

// Throws InputError (bad input/options, unwritable out_dir), EnvironmentError, Cancelled.
MappingReport RunMapping(const std::filesystem::path& input, const std::filesystem::path& out_dir,
                         const MappingOptions& options, const ProgressCallback& progress = {},
                         CancellationToken cancel = {});

}  // namespace glam
