// Ground-truth files of a synthetic clip (see the Contracts in docs/architecture.md):
//   gt_trajectory.tum   one line per frame, `t tx ty tz qx qy qz qw`, world_from_cam, t = i / fps
//   intrinsics.json     written through engine/core/intrinsics_io.h
//   gt_surface.json + gt_heights.f32   the rendered heightfield (Heightfield::WriteGroundTruth)
//   synth.json          the options used (written last: its presence marks a complete clip)
#pragma once

#include <filesystem>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine/core/se3.h"

namespace glam::synth {

// Throws EnvironmentError if the file cannot be written.
void WriteTumTrajectory(const std::vector<SE3>& world_from_cam, double fps,
                        const std::filesystem::path& path);

// Reads a TUM file written above (used by tests and by the skip-if-unchanged check).
// Throws InputError on a malformed line.
std::vector<SE3> ReadTumTrajectory(const std::filesystem::path& path, std::vector<double>* times);

void WriteJson(const nlohmann::json& json, const std::filesystem::path& path);

}  // namespace glam::synth
