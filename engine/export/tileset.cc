#include "engine/export/tileset.h"

#include <fmt/format.h>

#include <algorithm>

namespace glam {
namespace {

using nlohmann::json;

// A box with zero extent along an axis (a flat or single-point tile) confuses culling in some
// clients; give every half axis at least this fraction of the box diagonal (or 1 mm-ish in
// the frame's units for a single point).
double MinHalfSize(const Eigen::AlignedBox3d& box) {
  return std::max(1e-6 * box.diagonal().norm(), 1e-3);
}

json Box(const Eigen::AlignedBox3d& box) {
  const Eigen::Vector3d c = box.center();
  const double floor_half = MinHalfSize(box);
  const Eigen::Vector3d h = (0.5 * box.sizes()).cwiseMax(floor_half);
  return json::array({c.x(), c.y(), c.z(), h.x(), 0.0, 0.0, 0.0, h.y(), 0.0, 0.0, 0.0, h.z()});
}

// One child tile: `box` in the submap frame, placed by world_from_submap; grows `world`.
json Child(const Eigen::AlignedBox3d& box, const Sim3& world_from_submap, std::string uri, json extras,
           Eigen::AlignedBox3d* world) {
  const double floor_half = MinHalfSize(box);
  const Eigen::AlignedBox3d padded(box.min().array() - floor_half, box.max().array() + floor_half);
  for (int k = 0; k < 8; ++k) {
    world->extend(world_from_submap * padded.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k)));
  }
  json child;
  child["boundingVolume"] = {{"box", Box(box)}};
  child["geometricError"] = 0.0;
  child["refine"] = "ADD";
  child["transform"] = ColumnMajor(world_from_submap.matrix());
  child["content"] = {{"uri", std::move(uri)}};
  child["extras"] = std::move(extras);
  return child;
}

}  // namespace

std::string TileFileName(std::uint32_t submap_id, TileVariant variant) {
  return variant == TileVariant::kDraco ? fmt::format("tiles/{}.glb", submap_id)
                                        : fmt::format("tiles/{}.quantized.glb", submap_id);
}

std::string OpenTileFileName(std::uint32_t submap_id, TileVariant variant) {
  return variant == TileVariant::kDraco ? fmt::format("tiles/{}.open.glb", submap_id)
                                        : fmt::format("tiles/{}.open.quantized.glb", submap_id);
}

std::string TilesetFileName(TileVariant variant) {
  return variant == TileVariant::kDraco ? "tileset.json" : "tileset.quantized.json";
}

std::string TileUri(std::uint32_t submap_id, TileVariant variant, const std::string& run_id) {
  const std::string file = TileFileName(submap_id, variant);
  return run_id.empty() ? file : file + "?v=" + run_id;
}

json ColumnMajor(const Eigen::Matrix4d& m) {
  json out = json::array();
  for (int col = 0; col < 4; ++col) {
    for (int row = 0; row < 4; ++row) out.push_back(m(row, col));
  }
  return out;
}

json BuildTileset(const MapSnapshot& snapshot, const std::map<std::uint32_t, Eigen::AlignedBox3d>& bounds,
                  TileVariant variant, const std::string& run_id, const OpenTile* open) {
  json children = json::array();
  Eigen::AlignedBox3d world;  // root box: the children's boxes after their transforms
  for (const SubmapPlacement& placement : snapshot.submaps) {
    const auto found = bounds.find(placement.id);
    if (found == bounds.end() || found->second.isEmpty()) continue;
    children.push_back(Child(found->second, placement.world_from_submap, TileUri(placement.id, variant, run_id),
                             {{"submap", placement.id},
                              {"disconnected", placement.disconnected},
                              {"first_frame", placement.first_frame},
                              {"last_frame", placement.last_frame}},
                             &world));
  }
  if (open != nullptr && !open->bounds.isEmpty()) {
    const std::string version = fmt::format("{}{}open{}", run_id, run_id.empty() ? "" : "-", open->version);
    children.push_back(Child(open->bounds, open->world_from_submap,
                             OpenTileFileName(open->submap, variant) + "?v=" + version,
                             {{"submap", open->submap},
                              {"open", true},
                              {"disconnected", false},
                              {"keyframes", open->keyframes},
                              {"first_frame", open->first_frame},
                              {"last_frame", open->last_frame}},
                             &world));
  }
  if (world.isEmpty()) world = Eigen::AlignedBox3d(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());

  json root;
  root["boundingVolume"] = {{"box", Box(world)}};
  // Screen-space error of the (content-less) root: its size, so every client refines into the
  // children as soon as the map is on screen.
  root["geometricError"] = std::max(world.diagonal().norm(), 1.0);
  root["refine"] = "ADD";
  // A georeferenced map: the root's transform puts the east-north-up world on the globe; the
  // root box and the children's transforms stay in world coordinates beneath it.
  if (snapshot.ecef_from_world) root["transform"] = ColumnMajor(*snapshot.ecef_from_world);
  if (!children.empty()) root["children"] = std::move(children);

  json tileset;
  tileset["asset"] = {{"version", "1.1"},
                      {"tilesetVersion", std::to_string(snapshot.revision)}};
  tileset["geometricError"] = root["geometricError"];
  tileset["root"] = std::move(root);
  tileset["extras"] = {{"revision", snapshot.revision}};
  return tileset;
}

}  // namespace glam
