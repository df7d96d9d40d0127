// The whole-map files of a run (trajectory.tum, points.ply) from a published MapSnapshot and
// the submaps persisted on disk. Submaps are read back one at a time, so writing the map
// needs memory for the output, not for every submap's keyframes and descriptors at once.
//
// Submaps marked disconnected in the snapshot are left out of the map's files: their
// placement in the world is a guess, and a trajectory or point cloud with pieces in the wrong
// place is worse than one with a gap (the report counts their frames as unposed; graph.json
// and the tiles still have them). Each disconnected *part* (submaps linked to each other but
// not to the map, e.g. the flight after a tracking loss over water that never revisits
// earlier ground) is written on its own instead, in its own frame: parts/<n>/trajectory.tum
// and parts/<n>/points.ply, n = 1, 2, ... in order of the part's first frame. Its frame is
// built like the world frame (its first submap levelled), at its own scale: a part shares
// nothing with the map, so COLMAP-style separate models are all that can be said of it, and
// dropping it would lose what the video showed.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "engine/core/se3.h"
#include "engine/core/sim3.h"
#include "engine/export/colmap_model.h"
#include "engine/map/map_snapshot.h"
#include "engine/map/submap.h"

namespace glam {

// Frame index -> (frame_from_cam, posed by PnP) of the frames a model's submaps pose.
using ChosenPoses = std::map<std::int64_t, std::pair<SE3, bool>>;

// Adds the frame poses of `submap`, placed by `frame_from_submap`, to `poses`: the one rule
// for which submap's pose an overlap frame gets, in every output (trajectory.tum, map.glb's
// camera path, the georeference's camera centres). Submaps are added in id order, so an
// overlap frame keeps the earlier submap's pose, unless that one posed it without landmark
// matches (by rotation only, during a hovering yaw) and this one by PnP.
void AddFramePoses(const Submap& submap, const Sim3& frame_from_submap, ChosenPoses* poses);

// A submap placed in the frame of a model (the map's world frame, or a part's own frame).
struct PlacedSubmap {
  std::uint32_t id = 0;
  Sim3 frame_from_submap;
};

// A disconnected part of a snapshot: its submaps (ids ascending) in the part's own frame, which
// is built like the world frame (its first submap levelled, z up) at the part's own scale.
struct PartModel {
  std::vector<PlacedSubmap> submaps;
  std::int64_t first_frame = 0;
  std::int64_t last_frame = 0;
};

// The snapshot's disconnected parts in order of their first frame (the numbering of parts/<n>).
std::vector<PartModel> DisconnectedParts(const MapSnapshot& snapshot, const std::filesystem::path& submaps_root);
// The same with the levelling of each part's frame given: level(first submap id,
// part_from_first) -> levelled_from_part (LevelPart on the submap read from disk, above).
using PartLeveling = std::function<Sim3(std::uint32_t, const Sim3&)>;
std::vector<PartModel> DisconnectedParts(const MapSnapshot& snapshot, const PartLeveling& level);

// The map's (connected) submaps of a snapshot, ids ascending, placed in the world frame.
std::vector<PlacedSubmap> MapSubmaps(const MapSnapshot& snapshot);

// The camera centres (frame index -> centre) of chosen poses.
std::map<std::int64_t, Eigen::Vector3d> CameraCentres(const ChosenPoses& poses);

// Camera centres by frame index of the placed submaps (ids ascending), in their model's frame,
// one per frame by the rule of AddFramePoses.
std::map<std::int64_t, Eigen::Vector3d> CameraCentres(const std::vector<PlacedSubmap>& placed,
                                                      const std::filesystem::path& submaps_root);

// One disconnected part written to parts/<number>/.
struct PartExport {
  int number = 0;                      // 1-based, in order of first_frame
  std::vector<std::uint32_t> submaps;  // ids, ascending
  std::int64_t first_frame = 0;
  std::int64_t last_frame = 0;
  std::int64_t frames_posed = 0;  // distinct frames in its trajectory.tum
  std::int64_t points = 0;
};

struct MapExportCounts {
  std::int64_t frames_posed = 0;  // distinct frames in trajectory.tum (the map only)
  std::int64_t points = 0;
  std::int64_t submaps_exported = 0;  // submaps of the map
  std::vector<PartExport> parts;
};

// World camera centres of the map's frames (connected submaps; an overlap frame from the
// earlier submap, a PnP pose before a rotation-only one, as in trajectory.tum).
std::map<std::int64_t, Eigen::Vector3d> WorldCameraCentres(const MapSnapshot& snapshot,
                                                           const std::filesystem::path& submaps_root);

// Writes trajectory.tum (t = frame index / fps; a frame posed by two submaps, i.e. in an
// overlap, is written once, from the earlier submap unless only the later one posed it by
// PnP), points.ply and colmap/ (engine/export/colmap_model.h) into out_dir, and each
// disconnected part into out_dir/parts/<n>/ (the parts/ folder is replaced, so a re-run never
// leaves parts of an earlier run behind). image_names: the photos' file names by frame index,
// for the COLMAP model's images (empty for a video: frame_<index>.jpg); colmap_image_size: the
// input's image size, which the COLMAP model describes (default: the processing size).
MapExportCounts ExportWorldMap(const MapSnapshot& snapshot, const std::filesystem::path& submaps_root,
                               const std::filesystem::path& out_dir, double fps,
                               const std::vector<std::string>& image_names = {},
                               const ColmapImageSize& colmap_image_size = {});

}  // namespace glam
