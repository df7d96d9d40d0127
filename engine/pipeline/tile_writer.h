// Writes the map-delivery files of a mapping run while it runs (architecture "How data flows
// through one job"): each completed submap's tiles once, a new tileset.json per map revision,
// and map.glb at the end. The server serves these files from the job directory as they appear.
//
// Files under out_dir:
//   tiles/<id>.glb             Draco tile, submap frame (written once per submap)
//   tiles/<id>.quantized.glb   KHR_mesh_quantization variant of the same tile (written with it)
//   tileset.json               3D Tiles 1.1 over the Draco tiles, rewritten per revision
//   tileset.quantized.json     the same over the quantized tiles
//   tiles/<id>.open.glb        the open submap's provisional tile (both variants), rewritten as
//                              the submap grows and listed in the tilesets until the submap's
//                              own tile is (OnOpenSubmapPreview)
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
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "engine/export/glb_tile.h"
#include "engine/export/tileset.h"
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

  // The live preview of the submap being built (SubmapBuilder::OpenSubmapPreview): writes
  // tiles/<id>.open.glb (both variants) and rewrites the tilesets of the last written revision
  // with it (the revision number stays: previews are not map revisions). Placement:
  // world_from_anchor (the anchor submap's placement in each revision written from now on) *
  // anchor_from_submap; without an anchor, anchor_from_submap is world_from_submap itself (the
  // first submap, levelled on its own, or in metres east-north-up by a GPS fit, which then
  // comes with the ENU frame's ecef_from_world for the tileset root while no revision has one).
  // A revision that places the submap itself, or that does not place the anchor (or marks it
  // disconnected), lists no preview. Returns false, and writes nothing, when the last written
  // revision does not place the anchor.
  bool OnOpenSubmapPreview(const Submap& preview, std::optional<std::uint32_t> anchor,
                           const Sim3& anchor_from_submap,
                           const std::optional<Eigen::Matrix4d>& ecef_from_world = std::nullopt);
  // Forgets the preview (its submap was discarded, or the run ends) and deletes its tiles;
  // rewrites the tilesets if they listed it.
  void ClearOpenPreview();
  // Whether the last written revision places submap `id` in the map (connected).
  bool placed(std::uint32_t id) const;
  // The submap id and first frame of the preview the tilesets may list, if any.
  std::optional<std::pair<std::uint32_t, std::int64_t>> open_preview() const;

 private:
  // Records the submap's bounds; only_missing: keep tile files that exist (resume).
  void WriteTiles(const Submap& submap, bool only_missing);
  // Both tilesets of `snapshot`, with the preview where it is placed (PlacedPreview).
  void WriteTilesets(const MapSnapshot& snapshot);
  // The preview as placed in `snapshot`; unset when the snapshot lists no preview (see
  // OnOpenSubmapPreview). Drops the preview once the snapshot places its submap.
  std::optional<OpenTile> PlacedPreview(const MapSnapshot& snapshot);
  void RemovePreviewFiles(std::uint32_t submap_id) const;
  bool PlacedLocked(std::uint32_t id) const;

  struct Preview {
    OpenTile tile;  // world_from_submap filled in per revision
    std::optional<std::uint32_t> anchor;
    Sim3 anchor_from_submap;
    std::optional<Eigen::Matrix4d> ecef_from_world;  // without an anchor: placed by a GPS fit
  };

  std::filesystem::path out_dir_;
  std::string run_id_;
  DracoTileOptions draco_;
  mutable std::mutex mutex_;
  std::map<std::uint32_t, Eigen::AlignedBox3d> bounds_;  // submap id -> tile bounds
  std::int64_t last_revision_ = -1;
  MapSnapshot last_snapshot_;  // of last_revision_ (empty, revision 0, before the first)
  std::optional<Preview> preview_;
  std::int64_t preview_version_ = 0;
};

}  // namespace glam
