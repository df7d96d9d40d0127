// Puts a finished map in metres, east-north-up, from the GPS track of its video (engine/geo),
// as one more map revision; and places the flight's disconnected parts by GPS as well.
//
// Why parts too: a part is a piece of the flight the images could not link to the rest (a
// tracking loss over water, a cut in the video, new ground never seen again). Without GPS it
// can only be written on its own, in its own frame and scale (parts/<n>/). With GPS each part
// gets the same kind of fit as the map, into the same ENU frame (the track's first fix is the
// origin of every fit), so it joins the map's files: trajectory.tum, points.ply, the tiles and
// map.glb then hold the whole flight. Its placement relative to the rest is only as good as
// the GPS (the fit's rms says how good; a part too short or too noisy to fit stays a part), and
// report.json lists what was placed that way.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <vector>

#include "engine/geo/georeference.h"
#include "engine/geo/gps_track.h"
#include "engine/map/map_snapshot.h"
#include "engine/pipeline/map_export.h"

namespace glam {

// The GPS fit of one disconnected part (ok: it was placed in the map by it).
struct GpsPlacedPart {
  std::vector<std::uint32_t> submaps;  // ids, ascending
  std::int64_t first_frame = 0;
  std::int64_t last_frame = 0;
  GeoreferenceResult fit;  // enu_from_world here maps the part's own frame to ENU
};

struct MapGeoreference {
  GeoreferenceResult map;             // the fit of the map (the connected submaps)
  std::vector<GpsPlacedPart> parts;   // one per disconnected part, when the map's fit is ok
  // The georeferenced revision (revision + 1, every placement in ENU, ecef_from_world set);
  // null when the map's fit failed (the snapshot stays as it was).
  std::shared_ptr<const MapSnapshot> snapshot;
};

// Fits each part's camera centres (centres_of(part): by frame, in the part's own frame) to the
// GPS track on its own; a part whose fit succeeds joins `enu` (a snapshot already in the map's
// ENU frame: its submaps' placements become the fit times their place in the part, connected).
// One entry per part; log: say what happened to each (the final revision, not every live one).
std::vector<GpsPlacedPart> PlacePartsByGps(
    const std::vector<PartModel>& parts,
    const std::function<std::map<std::int64_t, Eigen::Vector3d>(const PartModel&)>& centres_of, double fps,
    const std::vector<GpsSample>& gps, const GeoreferenceOptions& options, MapSnapshot* enu, bool log);

// `submaps_root`: where the run's submaps are persisted (their frame poses give the camera
// centres). fps: the video's frame rate (frame index / fps = the GPS track's time).
MapGeoreference GeoreferenceMap(const MapSnapshot& snapshot, const std::filesystem::path& submaps_root, double fps,
                                const std::vector<GpsSample>& gps, const GeoreferenceOptions& options);

}  // namespace glam
