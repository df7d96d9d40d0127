#include "tests/support/exif_photo.h"

#include <libexif/exif-data.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <vector>

#include <opencv2/imgcodecs.hpp>

namespace glam::testing {
namespace {

ExifEntry* AddEntry(ExifData* data, ExifMem* mem, ExifTag tag, ExifFormat format, unsigned components,
                    ExifIfd ifd = EXIF_IFD_GPS) {
  ExifEntry* e = exif_entry_new_mem(mem);
  e->tag = tag;
  e->format = format;
  e->components = components;
  e->size = exif_format_get_size(format) * components;
  e->data = static_cast<unsigned char*>(exif_mem_alloc(mem, e->size));
  exif_content_add_entry(data->ifd[ifd], e);
  exif_entry_unref(e);
  return e;
}

void SetDms(ExifData* data, ExifMem* mem, ExifTag tag, double degrees) {
  ExifEntry* e = AddEntry(data, mem, tag, EXIF_FORMAT_RATIONAL, 3);
  const double d = std::floor(degrees), m = std::floor((degrees - d) * 60), s = ((degrees - d) * 60 - m) * 60;
  const ExifRational parts[3] = {{static_cast<ExifLong>(d), 1}, {static_cast<ExifLong>(m), 1},
                                 {static_cast<ExifLong>(std::llround(s * 10000)), 10000}};
  for (int i = 0; i < 3; ++i) exif_set_rational(e->data + 8 * i, EXIF_BYTE_ORDER_INTEL, parts[i]);
}

void SetRef(ExifData* data, ExifMem* mem, ExifTag tag, char ref) {
  ExifEntry* e = AddEntry(data, mem, tag, EXIF_FORMAT_ASCII, 2);
  e->data[0] = static_cast<unsigned char>(ref);
  e->data[1] = 0;
}

}  // namespace

void WritePhoto(const std::filesystem::path& path, const cv::Mat& image, const Geodetic* g,
                const std::string& date_time_original) {
  std::vector<unsigned char> jpeg;
  cv::imencode(".jpg", image, jpeg);
  if (g != nullptr || !date_time_original.empty()) {
    ExifMem* mem = exif_mem_new_default();
    ExifData* data = exif_data_new_mem(mem);
    exif_data_set_byte_order(data, EXIF_BYTE_ORDER_INTEL);
    if (!date_time_original.empty()) {
      ExifEntry* e = AddEntry(data, mem, EXIF_TAG_DATE_TIME_ORIGINAL, EXIF_FORMAT_ASCII,
                              static_cast<unsigned>(date_time_original.size() + 1), EXIF_IFD_EXIF);
      std::copy(date_time_original.begin(), date_time_original.end(), e->data);
      e->data[date_time_original.size()] = 0;
    }
    if (g != nullptr) {
      SetDms(data, mem, static_cast<ExifTag>(EXIF_TAG_GPS_LATITUDE), std::abs(g->latitude_deg));
      SetRef(data, mem, static_cast<ExifTag>(EXIF_TAG_GPS_LATITUDE_REF), g->latitude_deg < 0 ? 'S' : 'N');
      SetDms(data, mem, static_cast<ExifTag>(EXIF_TAG_GPS_LONGITUDE), std::abs(g->longitude_deg));
      SetRef(data, mem, static_cast<ExifTag>(EXIF_TAG_GPS_LONGITUDE_REF), g->longitude_deg < 0 ? 'W' : 'E');
      ExifEntry* alt = AddEntry(data, mem, static_cast<ExifTag>(EXIF_TAG_GPS_ALTITUDE), EXIF_FORMAT_RATIONAL, 1);
      exif_set_rational(alt->data, EXIF_BYTE_ORDER_INTEL,
                        {static_cast<ExifLong>(std::llround(std::abs(g->altitude_m) * 100)), 100});
      ExifEntry* alt_ref = AddEntry(data, mem, static_cast<ExifTag>(EXIF_TAG_GPS_ALTITUDE_REF), EXIF_FORMAT_BYTE, 1);
      alt_ref->data[0] = g->altitude_m < 0 ? 1 : 0;
    }
    unsigned char* block = nullptr;
    unsigned int size = 0;
    exif_data_save_data(data, &block, &size);  // "Exif\0\0" + TIFF
    // APP1 right after the start-of-image marker.
    std::vector<unsigned char> app1 = {0xFF, 0xE1, static_cast<unsigned char>((size + 2) >> 8),
                                       static_cast<unsigned char>((size + 2) & 0xFF)};
    app1.insert(app1.end(), block, block + size);
    jpeg.insert(jpeg.begin() + 2, app1.begin(), app1.end());
    std::free(block);
    exif_data_unref(data);
    exif_mem_unref(mem);
  }
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(jpeg.data()),
                                               static_cast<std::streamsize>(jpeg.size()));
}

}  // namespace glam::testing
