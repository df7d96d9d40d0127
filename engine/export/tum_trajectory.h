// trajectory.tum (architecture Contracts): one line per posed frame,
//   t tx ty tz qx qy qz qw
// with the pose world_from_cam and t = frame index / fps; unposed frames are simply absent.
// The same format carries the ground truth written by `glam synth`, and it is what standard
// trajectory tools (TUM scripts, evo) read, so results can be checked outside GLAM too.
// Files come from users (evaluation, resume), so every defect is an InputError that names the
// file and the line: a wrong file should produce a message, never a silently odd metric.
#pragma once

#include <filesystem>
#include <vector>

#include "engine/core/se3.h"

namespace glam {

struct TimedPose {
  double timestamp = 0;  // seconds (frame index / fps)
  SE3 world_from_cam;
};

// Reads a TUM trajectory. Blank lines and lines starting with '#' are skipped. Throws
// InputError (message: "<file>:<line>: ...") for a missing/unreadable file, a line that is
// not exactly 8 finite numbers, or a quaternion whose norm is not 1 (within 1e-4; values
// written with 6 decimals pass). Poses are returned in file order.
std::vector<TimedPose> ReadTumTrajectory(const std::filesystem::path& path);

// Writes poses in file order: timestamps with 9 decimals (frame times stay exact for hours of
// video), positions and quaternions with 9 significant digits (sub-millimetre for worlds of
// kilometres). Throws EnvironmentError if the file cannot be written.
void WriteTumTrajectory(const std::filesystem::path& path, const std::vector<TimedPose>& poses);

}  // namespace glam
