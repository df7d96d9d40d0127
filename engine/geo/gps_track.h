// GPS telemetry that comes with drone video. DJI drones write it next to each video as a
// subtitle file with the same name (`DJI_0001.MP4` + `DJI_0001.SRT`): one entry per frame (or
// per second on older models), its display time and a text line carrying the position, in one
// of the firmware's layouts:
//   [latitude: 22.123456] [longitude: 113.123456] [rel_alt: 50.000 abs_alt: 120.000]
//   [latitude : 22.1] [longtitude : 113.1] [altitude: 80.5]          (sic, older firmware)
//   GPS(113.1234,22.1234,16) BAROMETER:52.3                            (Phantom 4: lon, lat)
// Absolute altitude is preferred to the altitude above take-off where both are given (only
// the differences matter to the fit). Entries without a fix (0, 0) are skipped.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "engine/geo/geodetic.h"

namespace glam {

struct GpsSample {
  double time_s = 0;  // the entry's start time in the video
  Geodetic position;
};

// Throws InputError when the text has no entry with a position (naming what it expected).
std::vector<GpsSample> ParseDjiSrt(const std::string& text);
// Reads and parses a .srt file (InputError when unreadable or without positions).
std::vector<GpsSample> ReadGpsTrack(const std::filesystem::path& path);
// The telemetry file next to a video: same stem, extension .SRT or .srt; nullopt when there
// is none (or `video` is a folder).
std::optional<std::filesystem::path> FindGpsSidecar(const std::filesystem::path& video);

}  // namespace glam
