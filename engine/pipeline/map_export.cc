#include "engine/pipeline/map_export.h"

#include <map>
#include <vector>

#include "engine/export/ply_points.h"
#include "engine/export/tum_trajectory.h"
#include "engine/map/submap_io.h"

namespace glam {

SE3 WorldFromCam(const Sim3& world_from_submap, const SE3& cam_from_submap) {
  const SE3 submap_from_cam = cam_from_submap.Inverse();
  return SE3(world_from_submap.rotation() * submap_from_cam.rotation(),
             world_from_submap * submap_from_cam.translation());
}

MapExportCounts ExportWorldMap(const MapSnapshot& snapshot, const std::filesystem::path& submaps_root,
                               const std::filesystem::path& out_dir, double fps) {
  MapExportCounts counts;
  std::map<std::int64_t, SE3> poses;  // frame index -> world_from_cam
  std::vector<ColoredPoint> points;
  for (const SubmapPlacement& placement : snapshot.submaps) {
    if (placement.disconnected) continue;
    const Submap submap = ReadSubmap(submaps_root, placement.id);
    for (const FramePose& fp : submap.frame_poses) {
      poses.try_emplace(fp.frame_index, WorldFromCam(placement.world_from_submap, fp.cam_from_submap));
    }
    points.reserve(points.size() + submap.landmarks.size());
    for (const Landmark& lm : submap.landmarks) {
      ColoredPoint p;
      p.position = (placement.world_from_submap * lm.point_in_submap).cast<float>();
      p.color = lm.color;
      points.push_back(p);
    }
    ++counts.submaps_exported;
  }
  std::vector<TimedPose> timed;
  timed.reserve(poses.size());
  for (const auto& [index, pose] : poses) timed.push_back({static_cast<double>(index) / fps, pose});
  WriteTumTrajectory(out_dir / "trajectory.tum", timed);
  WritePlyPoints(out_dir / "points.ply", points);
  counts.frames_posed = static_cast<std::int64_t>(poses.size());
  counts.points = static_cast<std::int64_t>(points.size());
  return counts;
}

}  // namespace glam
