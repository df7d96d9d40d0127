// Ground-truth files of a synthetic clip (see the Contracts in docs/architecture.md):
//   gt_trajectory.tum   written through engine/export/tum_trajectory.h (world_from_cam, t = i / fps)
//   intrinsics.json     written through engine/core/intrinsics_io.h
//   gt_surface.json + gt_heights.f32   the rendered heightfield (Heightfield::WriteGroundTruth)
//   synth.json          the options used (written last: its presence marks a complete clip)
#pragma once

#include <filesystem>

#include <nlohmann/json.hpp>

namespace glam::synth {

void WriteJson(const nlohmann::json& json, const std::filesystem::path& path);

}  // namespace glam::synth
