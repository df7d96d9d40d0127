// Georeferencing while the map grows. Without it a GPS-tagged flight is shown in the mapping
// frame (the first submap's arbitrary scale and heading) for the whole run and jumps into
// metres, east-north-up only when the final revision is written (georeference_map.h). With it,
// every map revision thread 2 publishes is fitted to the GPS track as soon as the posed part of
// the flight is long enough for a fit (GeoreferenceOptions: ≥ 10 samples over ≥ 10 m), so the
// live viewer and 3D Tiles clients on a globe see the map in place and in metres from early
// in the run, and later revisions only refine that fit.
//
// Why a cache of poses: a fit per revision needs every connected frame's camera centre. Reading
// the submaps back from disk at every revision (as the final georeference does once) would cost
// O(submaps) reads per revision; the frame poses alone are ~80 bytes per frame (8 MB for a
// 100,000-frame flight), so they are kept from the moment a submap completes (or read from disk
// once, for the submaps of an interrupted run a resumed one starts after).
//
// A revision keeps its number: it is the same alignment state, expressed in ENU. Once a
// revision has been georeferenced, later ones stay in ENU: if a refit fails (e.g. GPS outliers
// dominate a short stretch) the last good fit is reused rather than switching the viewer back to
// the mapping frame. Disconnected parts (pieces of the flight the images could not link) are
// placed by their own fits as the final revision places them (PlacePartsByGps), so the live
// view shows a flight with a cut in one piece too; a part is fitted in its first submap's
// levelled frame (as GeoreferenceMap levels it), which needs that submap's landmarks: it is read
// from disk once when it first starts a part (rare), not levelled for every submap. The final
// revision's fits (GeoreferenceMap) are computed afresh on the whole map.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <vector>

#include "engine/geo/georeference.h"
#include "engine/geo/gps_track.h"
#include "engine/map/map_snapshot.h"
#include "engine/map/submap.h"
#include "engine/pipeline/map_export.h"

namespace glam {

class LiveGeoreferencer {
 public:
  // submaps_root: where completed submaps are persisted (read for submaps never passed to
  // AddSubmap, i.e. those of an interrupted run). fps: frame index / fps = GPS track time.
  LiveGeoreferencer(std::vector<GpsSample> gps, double fps, GeoreferenceOptions options,
                    std::filesystem::path submaps_root);

  // Keeps the completed submap's frame poses (nothing else) for later fits. The submap must be
  // persisted under submaps_root already (a part starting with it is levelled from the file).
  void AddSubmap(const Submap& submap);

  // The snapshot in metres, east-north-up (same revision, every placement composed with the
  // fit, each part with a fit of its own placed and connected, ecef_from_world set), or the
  // snapshot itself while no fit has succeeded yet.
  std::shared_ptr<const MapSnapshot> Apply(const std::shared_ptr<const MapSnapshot>& snapshot);

  // The fit the last georeferenced revision used (nullopt: none yet).
  const std::optional<GeoreferenceResult>& fit() const { return fit_; }

  // The same fit on a submap that is still being built, placed by world_from_submap in the
  // world the first revision will have (the live preview of the run's first submap, before any
  // revision exists: open_submap_preview.h); nullopt when its posed frames do not allow one yet.
  // Not kept: the revisions' fits are computed on completed submaps.
  std::optional<GeoreferenceResult> FitOpenSubmap(const Submap& open, const Sim3& world_from_submap) const;

 private:
  // The cached poses-only copy of submap `id`, read from disk on first use if needed.
  const Submap& Poses(std::uint32_t id);
  // LevelSubmap of submap `id` (read from disk, once): the frame of a part starting with it.
  const Sim3& LevelledFromSubmap(std::uint32_t id);
  // Frame -> camera centre of the placed submaps, by the rule of AddFramePoses.
  std::map<std::int64_t, Eigen::Vector3d> Centres(const std::vector<PlacedSubmap>& placed);

  std::vector<GpsSample> gps_;
  double fps_;
  GeoreferenceOptions options_;
  std::filesystem::path submaps_root_;
  std::map<std::uint32_t, Submap> poses_;  // submap id -> frame poses only
  std::map<std::uint32_t, Sim3> levelled_from_submap_;  // submaps that started a part
  std::optional<GeoreferenceResult> fit_;
};

}  // namespace glam
