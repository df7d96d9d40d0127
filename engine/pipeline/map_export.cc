#include "engine/pipeline/map_export.h"

#include <algorithm>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "engine/alignment/world_leveling.h"
#include "engine/core/error.h"
#include "engine/core/placed_pose.h"
#include "engine/export/colmap_model.h"
#include "engine/export/ply_points.h"
#include "engine/export/tum_trajectory.h"
#include "engine/map/submap_io.h"

namespace glam {
namespace {

namespace fs = std::filesystem;

struct ModelCounts {
  std::int64_t frames_posed = 0;
  std::int64_t points = 0;
};

// The submap's keyframes and landmarks in the model's frame; image_names: by frame index
// (photos), else empty.
void AddToColmapModel(const Submap& submap, const Sim3& frame_from_submap, const std::vector<std::string>& image_names,
                      ColmapModelWriter* colmap) {
  std::vector<ColmapImage> images;
  images.reserve(submap.keyframes.size());
  for (const Keyframe& kf : submap.keyframes) {
    const bool named = kf.frame_index >= 0 && kf.frame_index < static_cast<std::int64_t>(image_names.size());
    // The keyframe's camera: its submap's at the keyframe's own refined focal, as the bundle
    // adjustment projects it.
    images.push_back({kf.frame_index, CamFromWorld(frame_from_submap, kf.cam_from_submap),
                      submap.intrinsics.WithFocal(kf.focal),
                      named ? image_names[static_cast<std::size_t>(kf.frame_index)] : std::string()});
  }
  std::vector<ColmapPoint> points;
  points.reserve(submap.landmarks.size());
  for (const Landmark& lm : submap.landmarks) {
    ColmapPoint p;
    p.position_in_world = frame_from_submap * lm.point_in_submap;
    p.color = lm.color;
    p.observations.reserve(lm.observations.size());
    for (const Observation& obs : lm.observations) p.observations.emplace_back(obs.keyframe, obs.pixel.cast<double>());
    points.push_back(std::move(p));
  }
  colmap->Add(images, points);
}

// One model's trajectory.tum, points.ply and colmap/ (the COLMAP text model of its keyframes
// and landmarks) from its submaps (ids ascending).
ModelCounts WriteModel(const std::vector<PlacedSubmap>& placed, const fs::path& submaps_root,
                       const fs::path& dir, double fps, const std::vector<std::string>& image_names,
                       const ColmapImageSize& colmap_image_size) {
  ChosenPoses poses;
  std::vector<ColoredPoint> points;
  ColmapModelWriter colmap(dir / "colmap", colmap_image_size);
  for (const PlacedSubmap& entry : placed) {
    const Submap submap = ReadSubmap(submaps_root, entry.id);
    AddFramePoses(submap, entry.frame_from_submap, &poses);
    points.reserve(points.size() + submap.landmarks.size());
    for (const Landmark& lm : submap.landmarks) {
      ColoredPoint p;
      p.position = (entry.frame_from_submap * lm.point_in_submap).cast<float>();
      p.color = lm.color;
      points.push_back(p);
    }
    AddToColmapModel(submap, entry.frame_from_submap, image_names, &colmap);
  }
  colmap.Finish();
  std::vector<TimedPose> timed;
  timed.reserve(poses.size());
  for (const auto& [index, pose] : poses) timed.push_back({static_cast<double>(index) / fps, pose.first});
  WriteTumTrajectory(dir / "trajectory.tum", timed);
  WritePlyPoints(dir / "points.ply", points);
  return {static_cast<std::int64_t>(poses.size()), static_cast<std::int64_t>(points.size())};
}

}  // namespace

void AddFramePoses(const Submap& submap, const Sim3& frame_from_submap, ChosenPoses* poses) {
  for (const FramePose& fp : submap.frame_poses) {
    const bool by_pnp = fp.pnp_inliers > 0;
    const auto [it, added] =
        poses->try_emplace(fp.frame_index, WorldFromCam(frame_from_submap, fp.cam_from_submap), by_pnp);
    if (!added && by_pnp && !it->second.second) {
      it->second = {WorldFromCam(frame_from_submap, fp.cam_from_submap), true};
    }
  }
}

std::vector<PlacedSubmap> MapSubmaps(const MapSnapshot& snapshot) {
  std::vector<PlacedSubmap> map;
  for (const SubmapPlacement& placement : snapshot.submaps) {
    if (!placement.disconnected) map.push_back({placement.id, placement.world_from_submap});
  }
  std::sort(map.begin(), map.end(), [](const PlacedSubmap& a, const PlacedSubmap& b) { return a.id < b.id; });
  return map;
}

std::map<std::int64_t, Eigen::Vector3d> CameraCentres(const ChosenPoses& poses) {
  std::map<std::int64_t, Eigen::Vector3d> centres;
  for (const auto& [index, pose] : poses) centres.emplace_hint(centres.end(), index, pose.first.translation());
  return centres;
}

std::map<std::int64_t, Eigen::Vector3d> CameraCentres(const std::vector<PlacedSubmap>& placed,
                                                      const fs::path& submaps_root) {
  ChosenPoses poses;
  for (const PlacedSubmap& entry : placed) {
    AddFramePoses(ReadSubmap(submaps_root, entry.id), entry.frame_from_submap, &poses);
  }
  return CameraCentres(poses);
}

std::map<std::int64_t, Eigen::Vector3d> WorldCameraCentres(const MapSnapshot& snapshot, const fs::path& submaps_root) {
  return CameraCentres(MapSubmaps(snapshot), submaps_root);
}

std::vector<PartModel> DisconnectedParts(const MapSnapshot& snapshot, const fs::path& submaps_root) {
  return DisconnectedParts(snapshot, [&submaps_root](std::uint32_t first, const Sim3& part_from_first) {
    return LevelPart(ReadSubmap(submaps_root, first), part_from_first);
  });
}

std::vector<PartModel> DisconnectedParts(const MapSnapshot& snapshot, const PartLeveling& level) {
  std::map<int, std::vector<const SubmapPlacement*>> members_of;  // part -> submaps, ids ascending
  std::vector<const SubmapPlacement*> sorted;
  for (const SubmapPlacement& placement : snapshot.submaps) sorted.push_back(&placement);
  std::sort(sorted.begin(), sorted.end(),
            [](const SubmapPlacement* a, const SubmapPlacement* b) { return a->id < b->id; });
  for (const SubmapPlacement* placement : sorted) {
    if (placement->disconnected) members_of[placement->part].push_back(placement);
  }
  std::vector<PartModel> parts;
  for (const auto& [unused, members] : members_of) {
    PartModel part;
    part.first_frame = members.front()->first_frame;
    // The part's frame: its first submap levelled, like the world frame of the map.
    const Sim3 levelled_from_part = level(members.front()->id, members.front()->part_from_submap);
    for (const SubmapPlacement* p : members) {
      part.submaps.push_back({p->id, levelled_from_part * p->part_from_submap});
      part.first_frame = std::min(part.first_frame, p->first_frame);
      part.last_frame = std::max(part.last_frame, p->last_frame);
    }
    parts.push_back(std::move(part));
  }
  std::stable_sort(parts.begin(), parts.end(),
                   [](const PartModel& a, const PartModel& b) { return a.first_frame < b.first_frame; });
  return parts;
}

MapExportCounts ExportWorldMap(const MapSnapshot& snapshot, const fs::path& submaps_root,
                               const fs::path& out_dir, double fps, const std::vector<std::string>& image_names,
                               const ColmapImageSize& colmap_image_size) {
  MapExportCounts counts;
  const std::vector<PlacedSubmap> map = MapSubmaps(snapshot);
  const ModelCounts written = WriteModel(map, submaps_root, out_dir, fps, image_names, colmap_image_size);
  counts.frames_posed = written.frames_posed;
  counts.points = written.points;
  counts.submaps_exported = static_cast<std::int64_t>(map.size());

  // Parts, numbered by their first frame.
  const fs::path parts_dir = out_dir / "parts";
  std::error_code error;
  fs::remove_all(parts_dir, error);
  if (error) throw EnvironmentError("cannot replace " + parts_dir.string() + ": " + error.message());
  for (const PartModel& model : DisconnectedParts(snapshot, submaps_root)) {
    PartExport part;
    part.number = static_cast<int>(counts.parts.size()) + 1;
    part.first_frame = model.first_frame;
    part.last_frame = model.last_frame;
    for (const PlacedSubmap& p : model.submaps) part.submaps.push_back(p.id);
    const fs::path dir = parts_dir / std::to_string(part.number);
    fs::create_directories(dir, error);
    if (error) throw EnvironmentError("cannot create " + dir.string() + ": " + error.message());
    const ModelCounts part_written = WriteModel(model.submaps, submaps_root, dir, fps, image_names, colmap_image_size);
    part.frames_posed = part_written.frames_posed;
    part.points = part_written.points;
    counts.parts.push_back(std::move(part));
  }
  return counts;
}

}  // namespace glam
