// Persisting completed submaps: `submaps/<id>/submap.bin`, one versioned binary file
// (magic "GLAMSUBM", version 1). Submaps live on disk so memory stays bounded on long videos
// and so a restarted job resumes from its last completed submap.
#pragma once

#include <filesystem>

#include "engine/map/submap.h"

namespace glam {

inline constexpr char kSubmapMagic[] = "GLAMSUBM";
inline constexpr std::uint32_t kSubmapFormatVersion = 1;

// Directory of submap `id` under a job's `submaps/` folder.
std::filesystem::path SubmapDirectory(const std::filesystem::path& submaps_root, std::uint32_t id);

// Writes atomically (temporary file + rename). Throws EnvironmentError on I/O failure.
void WriteSubmap(const Submap& submap, const std::filesystem::path& submaps_root);

// Throws InputError for a missing, foreign, truncated or future-version file.
Submap ReadSubmap(const std::filesystem::path& submaps_root, std::uint32_t id);

}  // namespace glam
