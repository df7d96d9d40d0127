#include "engine/pipeline/georeference_map.h"

#include "engine/core/logging.h"
#include "engine/geo/geodetic.h"
#include "engine/pipeline/map_export.h"

namespace glam {

std::vector<GpsPlacedPart> PlacePartsByGps(
    const std::vector<PartModel>& parts,
    const std::function<std::map<std::int64_t, Eigen::Vector3d>(const PartModel&)>& centres_of, double fps,
    const std::vector<GpsSample>& gps, const GeoreferenceOptions& options, MapSnapshot* enu, bool log) {
  std::vector<GpsPlacedPart> placed_parts;
  for (const PartModel& part : parts) {
    GpsPlacedPart placed;
    placed.first_frame = part.first_frame;
    placed.last_frame = part.last_frame;
    for (const PlacedSubmap& member : part.submaps) placed.submaps.push_back(member.id);
    placed.fit = FitGeoreference(centres_of(part), fps, gps, options);
    if (placed.fit.ok) {
      for (const PlacedSubmap& member : part.submaps) {
        for (SubmapPlacement& placement : enu->submaps) {
          if (placement.id != member.id) continue;
          placement.world_from_submap = placed.fit.enu_from_world * member.frame_from_submap;
          placement.part_from_submap = placement.world_from_submap;
          placement.part = 0;
          placement.disconnected = false;
        }
      }
      if (log) {
        GLAM_LOG_INFO("frames {}-{} (not linked to the map by the images) placed by GPS: {} positions, rms {:.2f} m",
                      placed.first_frame, placed.last_frame, placed.fit.samples_used, placed.fit.rms_m);
      }
    } else if (log) {
      GLAM_LOG_INFO("frames {}-{} stay a part of their own: {}", placed.first_frame, placed.last_frame,
                    placed.fit.reason);
    }
    placed_parts.push_back(std::move(placed));
  }
  return placed_parts;
}

MapGeoreference GeoreferenceMap(const MapSnapshot& snapshot, const std::filesystem::path& submaps_root, double fps,
                                const std::vector<GpsSample>& gps, const GeoreferenceOptions& options) {
  MapGeoreference result;
  result.map = FitGeoreference(WorldCameraCentres(snapshot, submaps_root), fps, gps, options);
  const GeoreferenceResult& geo = result.map;
  if (!geo.ok) return result;
  GLAM_LOG_INFO("georeferenced with {} of {} GPS positions ({} fit, rms {:.2f} m over {:.0f} m, {:.4g} m per map unit)",
                geo.samples_used, geo.samples_matched, geo.full ? "similarity" : "yaw-scale-offset", geo.rms_m,
                geo.extent_m, geo.enu_from_world.scale());
  // The map moves into metres, east-north-up: one more revision of every placement (a
  // disconnected submap's guessed placement moves with the map), now with where that frame
  // sits on the earth.
  auto georeferenced = std::make_shared<MapSnapshot>(snapshot);
  georeferenced->revision = snapshot.revision + 1;
  for (SubmapPlacement& placement : georeferenced->submaps) {
    placement.world_from_submap = geo.enu_from_world * placement.world_from_submap;
  }
  georeferenced->ecef_from_world = EnuFrame(geo.origin).EcefFromEnu();

  // Each disconnected part by its own fit into the same ENU frame (every fit's origin is the
  // track's first fix).
  result.parts = PlacePartsByGps(
      DisconnectedParts(snapshot, submaps_root),
      [&submaps_root](const PartModel& part) { return CameraCentres(part.submaps, submaps_root); }, fps, gps,
      options, georeferenced.get(), true);
  result.snapshot = std::move(georeferenced);
  return result;
}

}  // namespace glam
