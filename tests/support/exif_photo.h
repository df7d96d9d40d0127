// Writes a JPEG the way a drone's camera tags it: an EXIF GPS IFD (latitude, longitude as
// degrees / minutes / seconds rationals with N/S, E/W references; altitude with its
// above/below-sea-level reference), built through libexif and put in an APP1 segment.
#pragma once

#include <filesystem>

#include <opencv2/core.hpp>

#include "engine/geo/geodetic.h"

namespace glam::testing {

// `image` (8-bit BGR) as a JPEG at `path` whose EXIF says `g`; no EXIF at all when g is null.
void WritePhoto(const std::filesystem::path& path, const cv::Mat& image, const Geodetic* g);

}  // namespace glam::testing
