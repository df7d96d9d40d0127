// Writes the map-delivery files of a mapping run while it runs (architecture "How data flows
// through one job"): each completed submap's tiles once, a new tileset.json per map revision,
// and map.glb at the end. The server serves these files from the job directory as they appear.
//
// Files under out_dir:
//   tiles/<id>.glb             Draco tile, submap frame (written once per submap)
//   tiles/<id>.quantized.glb   KHR_mesh_quantization variant of the same tile (written with it)
//   tileset.json               3D Tiles 1.1 over the Draco tiles, rewritten per revision
//   tileset.quantized.json     the same over the quantized tiles
//   map.glb                    whole map in world frame (Draco), written by WriteMapGlb
// Every file is written atomically (WriteFileAtomically: temporary file + rename).
//
// Resume: a writer created on an existing output directory does not know the tiles of the
// submaps completed before; OnRevision reads such a submap back from out_dir/submaps once to
// get its bounds (and writes its tiles if they are missing).
//
// Thread safety: all methods may be called from different threads (a mutex serialises them).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "engine/export/glb_tile.h"
#include "engine/map/map_snapshot.h"
#include "engine/map/submap.h"

namespace glam {

// The tile content of a submap in its own frame: landmarks with colours and the camera
// centres of its frame poses (ordered by frame index).
TileGeometry SubmapTileGeometry(const Submap& submap);

class TileWriter {
 public:
  // run_id: versions the tile URIs in tileset.json (BuildTileset); a resumed run keeps the
  // interrupted run's id because it keeps that run's tiles.
  TileWriter(std::filesystem::path out_dir, std::string run_id, DracoTileOptions draco = {});

  // Writes tiles/<id>.glb and tiles/<id>.quantized.glb. An empty submap (no landmarks) gets
  // valid tiles without points; it has no child in the tileset.
  void OnSubmapCompleted(const Submap& submap);

  // Rewrites the tiles of submaps whose contents changed after completion (the end-of-run
  // global refinement, map_refinement.h) and gives every tile URI a new version, so clients
  // that cached the old tiles (served as immutable) fetch them again with the next tileset.
  void OnSubmapsRefined(const std::vector<Submap>& submaps);

  // Writes tileset.json and tileset.quantized.json for this snapshot unless a snapshot with
  // the same or a larger revision was written already (so calling it on every poll is cheap).
  void OnRevision(const MapSnapshot& snapshot);

  // map.glb: the connected submaps' points and camera centres in the world frame (Draco, the
  // same quantisation rule as tiles, over the whole map's box); an overlap frame's centre comes
  // from the submap trajectory.tum takes it from (AddFramePoses). Disconnected submaps are left
  // out, as in points.ply. Returns the number of points written.
  std::int64_t WriteMapGlb(const MapSnapshot& snapshot, const std::filesystem::path& submaps_root);

  std::int64_t last_revision_written() const;

 private:
  // Records the submap's bounds; only_missing: keep tile files that exist (resume).
  void WriteTiles(const Submap& submap, bool only_missing);

  std::filesystem::path out_dir_;
  std::string run_id_;
  DracoTileOptions draco_;
  mutable std::mutex mutex_;
  std::map<std::uint32_t, Eigen::AlignedBox3d> bounds_;  // submap id -> tile bounds
  std::int64_t last_revision_ = -1;
};

}  // namespace glam
