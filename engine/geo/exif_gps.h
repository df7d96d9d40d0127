// The GPS position a camera wrote into a photo's EXIF (GPS IFD: latitude, longitude and
// altitude with their reference tags), through libexif. Drone photos carry it as a rule (DJI,
// Parrot, Autel), so a photo folder is georeferenced the way a video with its .SRT is.
#pragma once

#include <filesystem>
#include <optional>
#include <vector>

#include "engine/geo/gps_track.h"

namespace glam {

// nullopt when the file has no EXIF, no GPS IFD, or no latitude / longitude (altitude 0 when
// absent). Never throws on a bad file.
std::optional<Geodetic> ReadExifGps(const std::filesystem::path& image);

// One sample per photo that has a position, time_s = the photo's index in `photos` (photo
// folders are mapped at 1 fps, so index = time, as in trajectory.tum).
std::vector<GpsSample> ExifGpsTrack(const std::vector<std::filesystem::path>& photos);

}  // namespace glam
