// Writes a JPEG the way a drone's camera tags it: an EXIF GPS IFD (latitude, longitude as
// degrees / minutes / seconds rationals with N/S, E/W references; altitude with its
// above/below-sea-level reference) and the capture time (DateTimeOriginal), built through
// libexif and put in an APP1 segment.
#pragma once

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "engine/geo/geodetic.h"

namespace glam::testing {

// `image` (8-bit BGR) as a JPEG at `path` whose EXIF says `g` (no GPS IFD when null) and
// `date_time_original` ("YYYY:MM:DD HH:MM:SS"; none when empty); no EXIF at all without both.
void WritePhoto(const std::filesystem::path& path, const cv::Mat& image, const Geodetic* g,
                const std::string& date_time_original = "");

}  // namespace glam::testing
