#include "engine/video/photo_capture_time.h"

#include <libexif/exif-data.h>

#include <cctype>
#include <cstdio>
#include <memory>

namespace glam {
namespace {

struct ExifDataDeleter {
  void operator()(ExifData* d) const { exif_data_unref(d); }
};

// An ASCII entry of the EXIF sub-IFD as a string (without the terminating NUL); empty if absent.
std::string AsciiEntry(ExifData* data, ExifTag tag) {
  ExifEntry* e = exif_content_get_entry(data->ifd[EXIF_IFD_EXIF], tag);
  if (e == nullptr || e->format != EXIF_FORMAT_ASCII || e->data == nullptr || e->size == 0) return {};
  std::string value(reinterpret_cast<const char*>(e->data), e->size);
  value.erase(value.find_last_not_of(std::string("\0 ", 2)) + 1);
  return value;
}

// Days from 1970-01-01 to the given proleptic Gregorian date (H. Hinnant's days_from_civil).
std::int64_t DaysFromCivil(std::int64_t y, unsigned m, unsigned d) {
  y -= m <= 2 ? 1 : 0;
  const std::int64_t era = (y >= 0 ? y : y - 399) / 400;
  const auto yoe = static_cast<unsigned>(y - era * 400);
  const unsigned doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  const unsigned doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  return era * 146097 + static_cast<std::int64_t>(doe) - 719468;
}

}  // namespace

std::optional<std::int64_t> ParseExifDateTimeMs(const std::string& date_time, const std::string& sub_seconds) {
  // Exactly "YYYY:MM:DD HH:MM:SS" (cameras without a set clock write zeros or blanks).
  if (date_time.size() != 19) return std::nullopt;
  for (std::size_t i = 0; i < date_time.size(); ++i) {
    const char c = date_time[i];
    const bool separator = i == 4 || i == 7 || i == 10 || i == 13 || i == 16;
    if (separator ? (i == 10 ? c != ' ' : c != ':') : !std::isdigit(static_cast<unsigned char>(c))) {
      return std::nullopt;
    }
  }
  const auto number = [&date_time](std::size_t pos, std::size_t len) {
    return std::stoi(date_time.substr(pos, len));
  };
  const int year = number(0, 4), month = number(5, 2), day = number(8, 2);
  const int hour = number(11, 2), minute = number(14, 2), second = number(17, 2);
  if (year < 1900 || month < 1 || month > 12 || day < 1 || day > 31 || hour > 23 || minute > 59 || second > 60) {
    return std::nullopt;
  }
  std::int64_t ms = (DaysFromCivil(year, static_cast<unsigned>(month), static_cast<unsigned>(day)) * 86400 +
                     hour * 3600 + minute * 60 + second) *
                    1000;
  // Sub-seconds are the digits of a decimal fraction ("5" = 0.5 s, "057" = 0.057 s).
  int scale = 100;
  for (const char c : sub_seconds) {
    if (!std::isdigit(static_cast<unsigned char>(c)) || scale == 0) break;
    ms += (c - '0') * scale;
    scale /= 10;
  }
  return ms;
}

std::optional<std::int64_t> ReadPhotoCaptureTimeMs(const std::filesystem::path& image) {
  std::unique_ptr<ExifData, ExifDataDeleter> data(exif_data_new_from_file(image.c_str()));
  if (!data || data->ifd[EXIF_IFD_EXIF] == nullptr) return std::nullopt;
  return ParseExifDateTimeMs(AsciiEntry(data.get(), EXIF_TAG_DATE_TIME_ORIGINAL),
                             AsciiEntry(data.get(), EXIF_TAG_SUB_SEC_TIME_ORIGINAL));
}

}  // namespace glam
