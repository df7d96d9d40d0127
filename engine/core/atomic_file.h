// Small text files that other processes read while we write them (report.json, graph.json,
// checkpoint.json, tileset.json): written to `path.tmp` and renamed over `path`, so a reader —
// or a run resumed after a crash — sees the old file or the new one, never half of one.
#pragma once

#include <filesystem>
#include <string_view>

namespace glam {

// Throws EnvironmentError (naming the file) when the file cannot be written or renamed.
void WriteFileAtomically(const std::filesystem::path& path, std::string_view contents);

}  // namespace glam
