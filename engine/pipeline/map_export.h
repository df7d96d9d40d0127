// The whole-map files of a run (trajectory.tum, points.ply) from a published MapSnapshot and
// the submaps persisted on disk. Submaps are read back one at a time, so writing the map
// needs memory for the output, not for every submap's keyframes and descriptors at once.
//
// Submaps marked disconnected in the snapshot are left out: their placement is a guess, and a
// trajectory or point cloud with pieces in the wrong place is worse than one with a gap (the
// report counts their frames as unposed; graph.json and the tiles still have them).
#pragma once

#include <cstdint>
#include <filesystem>

#include "engine/core/se3.h"
#include "engine/core/sim3.h"
#include "engine/map/map_snapshot.h"

namespace glam {

// world_from_cam of a frame posed in a submap. TUM carries no scale, so the rotation is
// R_world_from_submap * R_submap_from_cam and the translation is the Sim3 applied to the
// camera centre (the camera's world position).
SE3 WorldFromCam(const Sim3& world_from_submap, const SE3& cam_from_submap);

struct MapExportCounts {
  std::int64_t frames_posed = 0;  // distinct frames in trajectory.tum
  std::int64_t points = 0;
  std::int64_t submaps_exported = 0;
};

// Writes trajectory.tum (t = frame index / fps; a frame posed by two submaps, i.e. in an
// overlap, is written once, from the earlier submap) and points.ply into out_dir.
MapExportCounts ExportWorldMap(const MapSnapshot& snapshot, const std::filesystem::path& submaps_root,
                               const std::filesystem::path& out_dir, double fps);

}  // namespace glam
