// When a photo was taken, from its EXIF (DateTimeOriginal, with SubSecTimeOriginal when the
// camera writes it), through libexif. A photo folder is mapped in capture order
// (ImageFolderSource): file names are the camera's counter, which restarts in every new DCIM
// folder (DJI: 100MEDIA/DJI_0001.JPG, 101MEDIA/DJI_0001.JPG, ...) and wraps at 9999, so photos
// gathered from several folders or cards, or renamed on upload, are out of order by name, and
// a photo sequence in the wrong order is a flight that jumps back and forth.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace glam {

// Milliseconds since 1970-01-01 00:00 of the camera's clock (its local time read as if it were
// UTC: only the order and differences matter). nullopt when the file has no EXIF or no valid
// DateTimeOriginal. Never throws on a bad file.
std::optional<std::int64_t> ReadPhotoCaptureTimeMs(const std::filesystem::path& image);

// "YYYY:MM:DD HH:MM:SS" (EXIF's format) plus optional sub-second digits -> milliseconds as
// above; nullopt for anything else (including EXIF's "0000:00:00 00:00:00" for unknown).
std::optional<std::int64_t> ParseExifDateTimeMs(const std::string& date_time, const std::string& sub_seconds = "");

}  // namespace glam
