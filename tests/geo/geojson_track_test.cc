// trajectory.geojson: RFC 7946 structure (FeatureCollection, one LineString, [lon, lat, alt]
// order), the coordinates are the given positions to ~1 mm, the times and frames run parallel
// to them, and the degenerate paths (none, one frame) are still valid GeoJSON.
#include "engine/geo/geojson_track.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace glam {
namespace {

using nlohmann::json;

TEST(GeoJsonTrack, ALineStringOfLongitudeLatitudeAltitude) {
  const EnuFrame frame({46.95, 7.45, 550});
  std::vector<GeoPathPoint> path;
  for (int i = 0; i < 5; ++i) {
    path.push_back({10 + i, (10 + i) / 30.0, frame.GeodeticFromEnu(Eigen::Vector3d(3.0 * i, -1.5 * i, 100 + i))});
  }
  const json j = json::parse(GeoJsonTrack(path, "DJI_0001.MP4"));
  EXPECT_EQ(j["type"], "FeatureCollection");
  ASSERT_EQ(j["features"].size(), 1u);
  const json& feature = j["features"][0];
  EXPECT_EQ(feature["type"], "Feature");
  EXPECT_EQ(feature["geometry"]["type"], "LineString");
  EXPECT_EQ(feature["properties"]["name"], "DJI_0001.MP4");
  const json& coordinates = feature["geometry"]["coordinates"];
  ASSERT_EQ(coordinates.size(), path.size());
  for (std::size_t i = 0; i < path.size(); ++i) {
    // Longitude first (RFC 7946), then latitude, then altitude; within ~1 mm of the position.
    const Geodetic back{coordinates[i][1].get<double>(), coordinates[i][0].get<double>(), coordinates[i][2].get<double>()};
    EXPECT_LT((frame.EnuFromGeodetic(back) - frame.EnuFromGeodetic(path[i].position)).norm(), 2e-3);
    EXPECT_EQ(feature["properties"]["frames"][i], path[i].frame);
    EXPECT_NEAR(feature["properties"]["times_s"][i].get<double>(), path[i].time_s, 1e-6);
  }
  EXPECT_NEAR(coordinates[0][0].get<double>(), 7.45, 1e-9);  // the first point is the origin
  EXPECT_NEAR(coordinates[0][1].get<double>(), 46.95, 1e-9);
}

TEST(GeoJsonTrack, EmptyAndSingleFramePathsAreValid) {
  json j = json::parse(GeoJsonTrack({}, "x"));
  EXPECT_EQ(j["type"], "FeatureCollection");
  EXPECT_TRUE(j["features"].empty());
  j = json::parse(GeoJsonTrack({{0, 0.0, Geodetic{47.0, 8.0, 400}}}, "x"));
  EXPECT_EQ(j["features"][0]["geometry"]["type"], "Point");  // a LineString needs two positions
  EXPECT_EQ(j["features"][0]["geometry"]["coordinates"][0], 8.0);
}

}  // namespace
}  // namespace glam
