#include "engine/geo/geojson_track.h"

#include <cmath>

#include <nlohmann/json.hpp>

namespace glam {
namespace {

// Degrees to 8 decimals and metres to millimetres: GeoJSON text stays small and diffable.
double Round(double value, double scale) { return std::round(value * scale) / scale; }

}  // namespace

std::string GeoJsonTrack(const std::vector<GeoPathPoint>& path, const std::string& name) {
  nlohmann::json features = nlohmann::json::array();
  if (!path.empty()) {
    nlohmann::json coordinates = nlohmann::json::array();
    nlohmann::json times = nlohmann::json::array();
    nlohmann::json frames = nlohmann::json::array();
    for (const GeoPathPoint& p : path) {
      coordinates.push_back({Round(p.position.longitude_deg, 1e8), Round(p.position.latitude_deg, 1e8),
                             Round(p.position.altitude_m, 1e3)});
      times.push_back(Round(p.time_s, 1e6));
      frames.push_back(p.frame);
    }
    // A LineString needs two positions; a single posed frame is a Point.
    nlohmann::json geometry = path.size() >= 2 ? nlohmann::json{{"type", "LineString"}, {"coordinates", coordinates}}
                                               : nlohmann::json{{"type", "Point"}, {"coordinates", coordinates[0]}};
    features.push_back({{"type", "Feature"},
                        {"geometry", std::move(geometry)},
                        {"properties", {{"name", name}, {"times_s", std::move(times)}, {"frames", std::move(frames)}}}});
  }
  return nlohmann::json{{"type", "FeatureCollection"}, {"features", std::move(features)}}.dump();
}

}  // namespace glam
