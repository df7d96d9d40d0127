// EXIF GPS of photos (engine/geo/exif_gps.h): JPEGs written with a GPS IFD as a drone's camera
// writes it (tests/support/exif_photo.h).
#include "engine/geo/exif_gps.h"

#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "tests/support/exif_photo.h"
#include "tests/support/temp_dir.h"

namespace glam {
namespace {

namespace fs = std::filesystem;
using glam::testing::WritePhoto;

const cv::Mat kImage(48, 64, CV_8UC3, cv::Scalar(40, 120, 200));

TEST(ExifGps, ReadsTheGpsOfDronePhotos) {
  const fs::path dir = glam::testing::FreshTempDir("exif_gps");
  const Geodetic north_east{46.842607, 7.994559, 198.31};
  const Geodetic south_west{-33.8675, -70.651, -12.5};
  WritePhoto(dir / "a.jpg", kImage, &north_east);
  WritePhoto(dir / "b.jpg", kImage, &south_west);
  WritePhoto(dir / "c.jpg", kImage, nullptr);
  std::ofstream(dir / "d.jpg") << "not a jpeg";
  const std::optional<Geodetic> a = ReadExifGps(dir / "a.jpg");
  ASSERT_TRUE(a.has_value());
  EXPECT_NEAR(a->latitude_deg, north_east.latitude_deg, 1e-7);  // 0.0001" of arc ~ 3 mm
  EXPECT_NEAR(a->longitude_deg, north_east.longitude_deg, 1e-7);
  EXPECT_NEAR(a->altitude_m, north_east.altitude_m, 0.005);
  const std::optional<Geodetic> b = ReadExifGps(dir / "b.jpg");
  ASSERT_TRUE(b.has_value());
  EXPECT_NEAR(b->latitude_deg, south_west.latitude_deg, 1e-7);  // S and W are negative
  EXPECT_NEAR(b->longitude_deg, south_west.longitude_deg, 1e-7);
  EXPECT_NEAR(b->altitude_m, south_west.altitude_m, 0.005);  // below sea level
  EXPECT_FALSE(ReadExifGps(dir / "c.jpg").has_value());
  EXPECT_FALSE(ReadExifGps(dir / "d.jpg").has_value());
  EXPECT_FALSE(ReadExifGps(dir / "missing.jpg").has_value());
  // One sample per photo with a position, at its index (photo folders run at 1 fps).
  const std::vector<GpsSample> track = ExifGpsTrack({dir / "a.jpg", dir / "c.jpg", dir / "b.jpg"});
  ASSERT_EQ(track.size(), 2u);
  EXPECT_EQ(track[0].time_s, 0.0);
  EXPECT_EQ(track[1].time_s, 2.0);
}

}  // namespace
}  // namespace glam
