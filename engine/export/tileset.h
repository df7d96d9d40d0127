// tileset.json (3D Tiles 1.1) of a published MapSnapshot (architecture "Map delivery format",
// Contracts "Map revision" and "Tiles").
//
// Layout: a root without content whose box (world frame) contains every child; one child per
// submap with content.uri = that submap's tile, transform = world_from_submap as a
// column-major 4x4 (uniform scale), boundingVolume.box = the tile's axis-aligned bounds in the
// submap frame (z-up: clients rotate glTF y-up content to z-up before the transform, so the box
// and the transform are plain submap / world coordinates), geometricError 0 (a leaf holds all
// the detail there is), refine "ADD" and extras {submap, disconnected, first_frame,
// last_frame}. asset.tilesetVersion is the revision as a string and extras.revision the number.
// A georeferenced snapshot (MapSnapshot::ecef_from_world) gives the root a `transform`, ECEF
// from the east-north-up world, so globe clients (CesiumJS) show the map where it was flown;
// GLAM's own viewer ignores the root transform and shows the local frame.
//
// Because tiles never change after their submap completes, a new alignment result rewrites
// this small file only. Tiles are therefore served as immutable; but a job mapped again from
// the start (restart, another engine version) writes new tiles under the same file names, so
// content URIs carry the run's id as a query (`tiles/3.glb?v=<run_id>`): a client that cached
// an earlier run's tile asks for a new URL instead of reusing stale bytes.
//
// `open`, when given, adds the open submap's provisional tile after the snapshot's children:
// content.uri = tiles/<id>.open.glb?v=<run_id>-open<version>, extras {submap, open: true,
// disconnected: false, keyframes, first_frame, last_frame}. Clients replace it by the
// submap's own tile when a later tileset lists that instead.
//
// Submaps without a tile box (empty submaps) are left out of the children; the root then
// still exists (3D Tiles needs one) with a tiny box at the origin when there is no child.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "engine/map/map_snapshot.h"

namespace glam {

enum class TileVariant {
  kDraco,      // tiles/<id>.glb
  kQuantized,  // tiles/<id>.quantized.glb (KHR_mesh_quantization, for standard clients)
};

// Relative to the job / output directory, and the URI used in tileset.json.
std::string TileFileName(std::uint32_t submap_id, TileVariant variant);
// The open submap's provisional tile: tiles/<id>.open.glb / tiles/<id>.open.quantized.glb.
std::string OpenTileFileName(std::uint32_t submap_id, TileVariant variant);
// tileset.json or tileset.quantized.json.
std::string TilesetFileName(TileVariant variant);

// 16 numbers, column-major, of world_from_submap.matrix().
nlohmann::json ColumnMajor(const Eigen::Matrix4d& m);

// The content URI of a tile in tileset.json: TileFileName, plus `?v=<run_id>` when run_id is
// not empty.
std::string TileUri(std::uint32_t submap_id, TileVariant variant, const std::string& run_id);

// The submap being built, shown before it completes (the live preview, Contracts "Tiles";
// engine/pipeline/tile_writer.h): its provisional tile, rewritten as the submap grows, and a
// placement derived from the submap before it (or its own levelling for the first submap).
struct OpenTile {
  std::uint32_t submap = 0;
  Sim3 world_from_submap;
  Eigen::AlignedBox3d bounds;  // of the tile, submap frame
  std::int64_t keyframes = 0;
  std::int64_t first_frame = 0;
  std::int64_t last_frame = 0;
  std::int64_t version = 0;  // counts the tile's rewrites: its content URI changes with each
};

// `bounds`: submap id -> axis-aligned box of its tile in the submap frame (TileBounds).
// `run_id`: identifies the run that wrote the tiles (see above); may be empty.
nlohmann::json BuildTileset(const MapSnapshot& snapshot,
                            const std::map<std::uint32_t, Eigen::AlignedBox3d>& bounds,
                            TileVariant variant, const std::string& run_id = "",
                            const OpenTile* open = nullptr);

}  // namespace glam
