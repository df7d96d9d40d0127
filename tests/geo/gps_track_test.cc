#include "engine/geo/gps_track.h"

#include <fstream>

#include <gtest/gtest.h>

#include "engine/core/error.h"
#include "tests/support/temp_dir.h"

namespace glam {
namespace {

// Entries in the layouts of three DJI firmware generations, Windows line ends included.
TEST(GpsTrack, ParsesTheDjiSubtitleLayouts) {
  const std::string srt =
      "1\r\n00:00:00,000 --> 00:00:00,033\r\n<font size=\"28\">FrameCnt: 1, DiffTime: 33ms\r\n"
      "2024-05-01 10:00:00.000\r\n[iso: 100] [shutter: 1/500.0] [fnum: 2.8] [latitude: 47.376900] "
      "[longitude: 8.541700] [rel_alt: 50.000 abs_alt: 458.250] </font>\r\n\r\n"
      "2\n00:00:01,500 --> 00:00:01,533\n[latitude : 47.3770] [longtitude : 8.5418] [altitude: 460.5]\n\n"
      "3\n00:01:02,250 --> 00:01:03,000\nHOME(8.5,47.3) 2024.05.01 10:01:02\nGPS(8.5419,47.3771,16) BAROMETER:52.3\n\n"
      "4\n00:01:03,000 --> 00:01:04,000\n[latitude: 0.000000] [longitude: 0.000000] [rel_alt: 0.0 abs_alt: 0.0]\n";
  const std::vector<GpsSample> samples = ParseDjiSrt(srt);
  ASSERT_EQ(samples.size(), 3u);  // the entry without a fix is skipped
  EXPECT_DOUBLE_EQ(samples[0].time_s, 0.0);
  EXPECT_DOUBLE_EQ(samples[0].position.latitude_deg, 47.3769);
  EXPECT_DOUBLE_EQ(samples[0].position.longitude_deg, 8.5417);
  EXPECT_DOUBLE_EQ(samples[0].position.altitude_m, 458.25);  // absolute, not relative
  EXPECT_DOUBLE_EQ(samples[1].time_s, 1.5);
  EXPECT_DOUBLE_EQ(samples[1].position.longitude_deg, 8.5418);
  EXPECT_DOUBLE_EQ(samples[1].position.altitude_m, 460.5);
  EXPECT_DOUBLE_EQ(samples[2].time_s, 62.25);
  EXPECT_DOUBLE_EQ(samples[2].position.latitude_deg, 47.3771);  // GPS(lon, lat, alt)
  EXPECT_DOUBLE_EQ(samples[2].position.longitude_deg, 8.5419);
  EXPECT_DOUBLE_EQ(samples[2].position.altitude_m, 16);
}

TEST(GpsTrack, RejectsTextWithoutPositionsAndFindsTheSidecar) {
  EXPECT_THROW(ParseDjiSrt("1\n00:00:00,000 --> 00:00:01,000\nHello\n"), InputError);
  EXPECT_THROW(ParseDjiSrt(""), InputError);
  const std::filesystem::path dir = glam::testing::FreshTempDir("gps_sidecar");
  std::ofstream(dir / "DJI_0001.MP4") << "x";
  EXPECT_FALSE(FindGpsSidecar(dir / "DJI_0001.MP4").has_value());
  std::ofstream(dir / "DJI_0001.SRT") << "1\n00:00:00,000 --> 00:00:01,000\n[latitude: 1.5] [longitude: 2.5]\n";
  ASSERT_TRUE(FindGpsSidecar(dir / "DJI_0001.MP4").has_value());
  EXPECT_EQ(FindGpsSidecar(dir / "DJI_0001.MP4")->filename(), "DJI_0001.SRT");
  EXPECT_EQ(ReadGpsTrack(*FindGpsSidecar(dir / "DJI_0001.MP4")).size(), 1u);
  EXPECT_FALSE(FindGpsSidecar(dir).has_value());  // a folder has none
  EXPECT_THROW(ReadGpsTrack(dir / "missing.SRT"), InputError);
}

}  // namespace
}  // namespace glam
