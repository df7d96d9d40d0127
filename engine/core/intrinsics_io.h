// intrinsics.json (architecture Contracts):
//   {"model": "pinhole" | "radial", "width", "height", "fx", "fy", "cx", "cy", "k1", "k2"}
// k1, k2 are optional (default 0). The file is user input, so every problem is reported as
// an InputError that names the file and the field.
#pragma once

#include <filesystem>

#include "engine/core/camera.h"

namespace glam {

// Throws InputError on a missing/unreadable file, malformed JSON, a missing or mistyped
// field (named in the message), or values rejected by Intrinsics::Check().
Intrinsics ReadIntrinsicsJson(const std::filesystem::path& path);

// Throws InputError if the intrinsics fail Check(), EnvironmentError if the file cannot be
// written.
void WriteIntrinsicsJson(const Intrinsics& intrinsics, const std::filesystem::path& path);

}  // namespace glam
