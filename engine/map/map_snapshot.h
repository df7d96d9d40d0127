// One published state of the global map: where every submap currently sits in the world.
// Thread 2 publishes a new immutable snapshot with a larger revision after every alignment
// step; readers (the exporter, the server, tileset.json) hold a shared_ptr<const MapSnapshot>
// and never see a half-updated map. Submap contents never change after completion, so the
// placement per submap is all a revision needs (docs/architecture.md, "Map revision").
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "engine/core/sim3.h"

namespace glam {

struct SubmapPlacement {
  std::uint32_t id = 0;
  Sim3 world_from_submap;
  // Not (yet) linked to the main map: its placement is only a guess (it sits at the pose of
  // the submap before it), so whole-map exports leave it out and viewers mark it.
  bool disconnected = false;
  std::int64_t first_frame = 0;
  std::int64_t last_frame = 0;
  // Which disconnected part the submap belongs to (0: the map; submaps of one part share a
  // number, which is only meaningful within this snapshot) and where it sits in that part's
  // own frame (for the map: world_from_submap). A part's submaps are placed relative to each
  // other by their verified edges, so each part can be exported on its own (map_export.h).
  int part = 0;
  Sim3 part_from_submap;
};

struct MapSnapshot {
  std::int64_t revision = 0;
  std::vector<SubmapPlacement> submaps;  // in order of completion (ids ascending)
  // Where the world frame sits on the earth, once the map is georeferenced (engine/geo: the
  // world is then metres, east-north-up): the rigid map from world to earth-centred (ECEF)
  // coordinates. tileset.json writes it as its root transform, so 3D Tiles clients that show
  // a globe place the map where it was flown. Unset for maps in their own frame.
  std::optional<Eigen::Matrix4d> ecef_from_world;
};

}  // namespace glam
