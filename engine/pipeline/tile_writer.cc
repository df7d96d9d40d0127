#include "engine/pipeline/tile_writer.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>

#include "engine/core/atomic_file.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/export/tileset.h"
#include "engine/map/submap_io.h"
#include "engine/pipeline/map_export.h"

namespace glam {
namespace {

std::vector<Eigen::Vector3d> CameraCentres(const Submap& submap) {
  std::vector<const FramePose*> poses;
  poses.reserve(submap.frame_poses.size());
  for (const FramePose& fp : submap.frame_poses) poses.push_back(&fp);
  std::stable_sort(poses.begin(), poses.end(),
                   [](const FramePose* a, const FramePose* b) { return a->frame_index < b->frame_index; });
  std::vector<Eigen::Vector3d> centres;
  centres.reserve(poses.size());
  for (const FramePose* fp : poses) centres.push_back(fp->cam_from_submap.Inverse().translation());
  return centres;
}

// The snapshot's placement of submap `id`, or null.
const SubmapPlacement* FindPlacement(const MapSnapshot& snapshot, std::uint32_t id) {
  for (const SubmapPlacement& p : snapshot.submaps) {
    if (p.id == id) return &p;
  }
  return nullptr;
}

}  // namespace

TileGeometry SubmapTileGeometry(const Submap& submap) {
  TileGeometry geometry;
  geometry.points.reserve(submap.landmarks.size());
  for (const Landmark& lm : submap.landmarks) {
    ColoredPoint p;
    p.position = lm.point_in_submap.cast<float>();
    p.color = lm.color;
    geometry.points.push_back(p);
  }
  for (const Eigen::Vector3d& c : CameraCentres(submap)) geometry.trajectory.push_back(c.cast<float>());
  return geometry;
}

TileWriter::TileWriter(std::filesystem::path out_dir, std::string run_id, DracoTileOptions draco)
    : out_dir_(std::move(out_dir)), run_id_(std::move(run_id)), draco_(draco) {
  draco_.Check();
  std::error_code ec;
  std::filesystem::create_directories(out_dir_ / "tiles", ec);
  if (ec) {
    throw EnvironmentError(fmt::format("cannot create {}: {}", (out_dir_ / "tiles").string(), ec.message()));
  }
}

void TileWriter::WriteTiles(const Submap& submap, bool only_missing) {
  const TileGeometry geometry = SubmapTileGeometry(submap);
  const std::filesystem::path draco_path = out_dir_ / TileFileName(submap.id, TileVariant::kDraco);
  const std::filesystem::path quantized_path = out_dir_ / TileFileName(submap.id, TileVariant::kQuantized);
  if (!only_missing || !std::filesystem::exists(draco_path)) {
    WriteFileAtomically(draco_path, EncodeDracoTileGlb(geometry, draco_));
  }
  if (!only_missing || !std::filesystem::exists(quantized_path)) {
    WriteFileAtomically(quantized_path, EncodeQuantizedTileGlb(geometry));
  }
  bounds_[submap.id] = geometry.points.empty() ? Eigen::AlignedBox3d() : TileBounds(geometry);
}

void TileWriter::OnSubmapCompleted(const Submap& submap) {
  std::lock_guard lock(mutex_);
  WriteTiles(submap, false);
  GLAM_LOG_DEBUG("tile of submap {} written ({} points)", submap.id, submap.landmarks.size());
}

void TileWriter::OnSubmapsRefined(const std::vector<Submap>& submaps) {
  std::lock_guard lock(mutex_);
  for (const Submap& submap : submaps) WriteTiles(submap, false);
  run_id_ += run_id_.empty() ? "refined" : "-refined";
}

void TileWriter::OnRevision(const MapSnapshot& snapshot) {
  std::lock_guard lock(mutex_);
  if (snapshot.revision <= last_revision_) return;
  for (const SubmapPlacement& placement : snapshot.submaps) {
    if (bounds_.count(placement.id) != 0) continue;
    // Completed in an earlier run of a resumed job: read it back once.
    try {
      WriteTiles(ReadSubmap(out_dir_ / "submaps", placement.id), true);
    } catch (const InputError& e) {
      GLAM_LOG_WARN("submap {} has no tile: {}", placement.id, e.what());
      bounds_[placement.id] = Eigen::AlignedBox3d();
    }
  }
  WriteTilesets(snapshot);
  last_revision_ = snapshot.revision;
  last_snapshot_ = snapshot;
}

void TileWriter::WriteTilesets(const MapSnapshot& snapshot) {
  const std::optional<OpenTile> open = PlacedPreview(snapshot);
  // A first submap's preview placed by a GPS fit before any revision is georeferenced: the
  // tileset is in that ENU frame already.
  const bool georeferenced_preview =
      open && preview_ && preview_->ecef_from_world && !snapshot.ecef_from_world;
  MapSnapshot with_frame;
  if (georeferenced_preview) {
    with_frame = snapshot;
    with_frame.ecef_from_world = preview_->ecef_from_world;
  }
  const MapSnapshot& written = georeferenced_preview ? with_frame : snapshot;
  for (const TileVariant variant : {TileVariant::kDraco, TileVariant::kQuantized}) {
    WriteFileAtomically(out_dir_ / TilesetFileName(variant),
                        BuildTileset(written, bounds_, variant, run_id_, open ? &*open : nullptr).dump(1));
  }
}

std::optional<OpenTile> TileWriter::PlacedPreview(const MapSnapshot& snapshot) {
  if (!preview_) return std::nullopt;
  if (FindPlacement(snapshot, preview_->tile.submap) != nullptr) {  // its own tile is listed now
    RemovePreviewFiles(preview_->tile.submap);
    preview_.reset();
    return std::nullopt;
  }
  OpenTile tile = preview_->tile;
  if (!preview_->anchor) {
    tile.world_from_submap = preview_->anchor_from_submap;
    return tile;
  }
  const SubmapPlacement* anchor = FindPlacement(snapshot, *preview_->anchor);
  if (anchor == nullptr || anchor->disconnected) return std::nullopt;
  tile.world_from_submap = anchor->world_from_submap * preview_->anchor_from_submap;
  return tile;
}

bool TileWriter::OnOpenSubmapPreview(const Submap& preview, std::optional<std::uint32_t> anchor,
                                     const Sim3& anchor_from_submap,
                                     const std::optional<Eigen::Matrix4d>& ecef_from_world) {
  std::lock_guard lock(mutex_);
  if (anchor && !PlacedLocked(*anchor)) return false;
  if (FindPlacement(last_snapshot_, preview.id) != nullptr) return false;  // completed and placed already
  const TileGeometry geometry = SubmapTileGeometry(preview);
  if (geometry.points.empty()) return false;
  if (preview_ && preview_->tile.submap != preview.id) RemovePreviewFiles(preview_->tile.submap);
  WriteFileAtomically(out_dir_ / OpenTileFileName(preview.id, TileVariant::kDraco), EncodeDracoTileGlb(geometry, draco_));
  WriteFileAtomically(out_dir_ / OpenTileFileName(preview.id, TileVariant::kQuantized), EncodeQuantizedTileGlb(geometry));
  Preview next;
  next.tile.submap = preview.id;
  next.tile.bounds = TileBounds(geometry);
  next.tile.keyframes = static_cast<std::int64_t>(preview.keyframes.size());
  next.tile.first_frame = preview.first_frame;
  next.tile.last_frame = preview.last_frame;
  next.tile.version = ++preview_version_;
  next.anchor = anchor;
  next.anchor_from_submap = anchor_from_submap;
  if (!anchor) next.ecef_from_world = ecef_from_world;
  preview_ = std::move(next);
  WriteTilesets(last_snapshot_);
  return true;
}

bool TileWriter::PlacedLocked(std::uint32_t id) const {
  const SubmapPlacement* placement = FindPlacement(last_snapshot_, id);
  return placement != nullptr && !placement->disconnected;
}

bool TileWriter::placed(std::uint32_t id) const {
  std::lock_guard lock(mutex_);
  return PlacedLocked(id);
}

void TileWriter::ClearOpenPreview() {
  std::lock_guard lock(mutex_);
  if (!preview_) return;
  RemovePreviewFiles(preview_->tile.submap);
  preview_.reset();
  WriteTilesets(last_snapshot_);
}

std::optional<std::pair<std::uint32_t, std::int64_t>> TileWriter::open_preview() const {
  std::lock_guard lock(mutex_);
  if (!preview_) return std::nullopt;
  return std::make_pair(preview_->tile.submap, preview_->tile.first_frame);
}

void TileWriter::RemovePreviewFiles(std::uint32_t submap_id) const {
  for (const TileVariant variant : {TileVariant::kDraco, TileVariant::kQuantized}) {
    std::error_code ignored;  // a file that is gone already is fine
    std::filesystem::remove(out_dir_ / OpenTileFileName(submap_id, variant), ignored);
  }
}

std::int64_t TileWriter::WriteMapGlb(const MapSnapshot& snapshot, const std::filesystem::path& submaps_root) {
  TileGeometry world;
  ChosenPoses poses;  // the camera path: one pose per frame, as in trajectory.tum
  for (const SubmapPlacement& placement : snapshot.submaps) {
    if (placement.disconnected) continue;
    const Submap submap = ReadSubmap(submaps_root, placement.id);
    world.points.reserve(world.points.size() + submap.landmarks.size());
    for (const Landmark& lm : submap.landmarks) {
      ColoredPoint p;
      p.position = (placement.world_from_submap * lm.point_in_submap).cast<float>();
      p.color = lm.color;
      world.points.push_back(p);
    }
    AddFramePoses(submap, placement.world_from_submap, &poses);
  }
  for (const auto& [index, pose] : poses) world.trajectory.push_back(pose.first.translation().cast<float>());
  const std::string glb = EncodeDracoTileGlb(world, draco_);
  std::lock_guard lock(mutex_);
  WriteFileAtomically(out_dir_ / "map.glb", glb);
  return static_cast<std::int64_t>(world.points.size());
}

std::int64_t TileWriter::last_revision_written() const {
  std::lock_guard lock(mutex_);
  return last_revision_;
}

}  // namespace glam
