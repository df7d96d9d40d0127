// trajectory.geojson: a georeferenced flight path as GeoJSON (RFC 7946), the format every GIS
// and web map reads (QGIS, geojson.io, Leaflet, Google Earth through a converter), so the path
// a map says the drone flew can be laid over other data without knowing GLAM's local frame.
//
// One FeatureCollection with one LineString Feature: coordinates [longitude, latitude,
// altitude] in WGS84 degrees (8 decimals, ~1 mm) and the altitude of the GPS source (DJI's
// abs_alt is above mean sea level, EXIF GPSAltitude too; RFC 7946 asks for the ellipsoid, which
// differs by the geoid height: tens of metres, so altitudes are for relative use). The
// properties carry the frames' times (seconds, as trajectory.tum) and indices, in the order of
// the coordinates.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "engine/geo/geodetic.h"

namespace glam {

// Its file name in a mapping run's output directory (written only for georeferenced maps).
inline constexpr char kGeoJsonTrackFile[] = "trajectory.geojson";

struct GeoPathPoint {
  std::int64_t frame = 0;
  double time_s = 0;
  Geodetic position;
};

// The GeoJSON text (compact). An empty path gives a FeatureCollection without features.
std::string GeoJsonTrack(const std::vector<GeoPathPoint>& path, const std::string& name);

}  // namespace glam
