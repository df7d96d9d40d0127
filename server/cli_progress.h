// Progress on the terminal for the `glam` commands that wait on long work (map, upload): a
// one-line bar redrawn in place when stderr is a terminal, log lines otherwise (CI, files).
#pragma once

#include <cstdint>
#include <string>

#include "engine/pipeline/progress.h"

namespace glam::cli {

// "mm:ss" or "h:mm:ss"; "--:--" for a negative (unknown) duration.
std::string FormatDuration(double seconds);

// A mapping run's progress: stage, bar, frames, fps, ETA, submaps, keyframes.
void DrawProgress(const MappingProgress& p, bool tty);

// An upload's progress: bar, bytes sent of the total, rate, ETA, and the reason of a retry.
void DrawUploadProgress(const std::string& label, std::int64_t sent, std::int64_t total, double bytes_per_s,
                        const std::string& retry, bool tty);

}  // namespace glam::cli
