#include "engine/geo/exif_gps.h"

#include <libexif/exif-data.h>

#include <memory>

namespace glam {
namespace {

struct ExifDataDeleter {
  void operator()(ExifData* d) const { exif_data_unref(d); }
};

// Degrees from the three rationals (degrees, minutes, seconds) of a GPS coordinate tag.
std::optional<double> Coordinate(ExifData* data, ExifTag tag) {
  ExifEntry* e = exif_content_get_entry(data->ifd[EXIF_IFD_GPS], tag);
  if (e == nullptr || e->format != EXIF_FORMAT_RATIONAL || e->components < 3) return std::nullopt;
  const ExifByteOrder order = exif_data_get_byte_order(data);
  const std::size_t size = exif_format_get_size(EXIF_FORMAT_RATIONAL);
  double value = 0;
  double unit = 1;
  for (unsigned i = 0; i < 3; ++i) {
    const ExifRational r = exif_get_rational(e->data + i * size, order);
    if (r.denominator == 0) return std::nullopt;
    value += static_cast<double>(r.numerator) / r.denominator / unit;
    unit *= 60;
  }
  return value;
}

char Reference(ExifData* data, ExifTag tag) {
  ExifEntry* e = exif_content_get_entry(data->ifd[EXIF_IFD_GPS], tag);
  return e != nullptr && e->size > 0 && e->data != nullptr ? static_cast<char>(e->data[0]) : '\0';
}

}  // namespace

std::optional<Geodetic> ReadExifGps(const std::filesystem::path& image) {
  std::unique_ptr<ExifData, ExifDataDeleter> data(exif_data_new_from_file(image.c_str()));
  if (!data || data->ifd[EXIF_IFD_GPS] == nullptr) return std::nullopt;
  const std::optional<double> lat = Coordinate(data.get(), static_cast<ExifTag>(EXIF_TAG_GPS_LATITUDE));
  const std::optional<double> lon = Coordinate(data.get(), static_cast<ExifTag>(EXIF_TAG_GPS_LONGITUDE));
  if (!lat || !lon) return std::nullopt;
  Geodetic g;
  g.latitude_deg = Reference(data.get(), static_cast<ExifTag>(EXIF_TAG_GPS_LATITUDE_REF)) == 'S' ? -*lat : *lat;
  g.longitude_deg = Reference(data.get(), static_cast<ExifTag>(EXIF_TAG_GPS_LONGITUDE_REF)) == 'W' ? -*lon : *lon;
  ExifEntry* alt = exif_content_get_entry(data->ifd[EXIF_IFD_GPS], static_cast<ExifTag>(EXIF_TAG_GPS_ALTITUDE));
  if (alt != nullptr && alt->format == EXIF_FORMAT_RATIONAL && alt->components >= 1) {
    const ExifRational r = exif_get_rational(alt->data, exif_data_get_byte_order(data.get()));
    if (r.denominator != 0) {
      g.altitude_m = static_cast<double>(r.numerator) / r.denominator;
      // GPSAltitudeRef 1: below sea level.
      ExifEntry* ref = exif_content_get_entry(data->ifd[EXIF_IFD_GPS], static_cast<ExifTag>(EXIF_TAG_GPS_ALTITUDE_REF));
      if (ref != nullptr && ref->size > 0 && ref->data[0] == 1) g.altitude_m = -g.altitude_m;
    }
  }
  if (g.latitude_deg == 0 && g.longitude_deg == 0) return std::nullopt;  // no fix
  return g;
}

std::vector<GpsSample> ExifGpsTrack(const std::vector<std::filesystem::path>& photos) {
  std::vector<GpsSample> samples;
  for (std::size_t i = 0; i < photos.size(); ++i) {
    if (const std::optional<Geodetic> g = ReadExifGps(photos[i])) samples.push_back({static_cast<double>(i), *g});
  }
  return samples;
}

}  // namespace glam
