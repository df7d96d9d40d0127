// World poses written to trajectory.tum: world_from_cam composed from world_from_submap (Sim3)
// and cam_from_submap (SE3), with scale acting on the position only; overlap frames come from
// the earlier submap; disconnected submaps stay out of the whole-map files.
#include "engine/pipeline/map_export.h"

#include <gtest/gtest.h>

#include "engine/export/ply_points.h"
#include "engine/export/tum_trajectory.h"
#include "engine/map/submap_io.h"

namespace glam {
namespace {

TEST(MapExport, WorldFromCamComposesSim3AndCameraPose) {
  const Sim3 world_from_submap(3.0, SO3::Exp(Eigen::Vector3d(0.1, -0.2, 0.5)), Eigen::Vector3d(4, 5, 6));
  const SE3 cam_from_submap(SO3::Exp(Eigen::Vector3d(-0.3, 0.4, 0.2)), Eigen::Vector3d(1, -2, 0.5));
  const SE3 world_from_cam = WorldFromCam(world_from_submap, cam_from_submap);
  // Camera centre: the camera-frame origin maps to the camera's world position.
  const Eigen::Vector3d centre_submap = cam_from_submap.Inverse().translation();
  EXPECT_LT((world_from_cam.translation() - world_from_submap * centre_submap).norm(), 1e-12);
  // Directions: a viewing ray in the camera frame maps like world_from_submap's rotation.
  const Eigen::Vector3d ray_cam(0.2, -0.1, 1.0);
  const Eigen::Vector3d ray_submap = cam_from_submap.Inverse().rotation() * ray_cam;
  const Eigen::Vector3d expected = world_from_submap.rotation() * ray_submap;
  EXPECT_LT((world_from_cam.rotation() * ray_cam - expected).norm(), 1e-12);
  // A point seen by the camera lands where the Sim3 puts it, up to the scale along the ray.
  const Eigen::Vector3d p_submap(3, 1, 7);
  const Eigen::Vector3d p_world = world_from_submap * p_submap;
  const Eigen::Vector3d p_cam = cam_from_submap * p_submap;
  EXPECT_LT((world_from_cam * (3.0 * p_cam) - p_world).norm(), 1e-9);
}

Submap FrameOnlySubmap(std::uint32_t id, std::int64_t first, std::int64_t last, double x) {
  Submap s;
  s.id = id;
  s.first_frame = first;
  s.last_frame = last;
  for (std::int64_t i = first; i <= last; ++i) {
    FramePose fp;
    fp.frame_index = i;
    fp.cam_from_submap = SE3(SO3(), Eigen::Vector3d(-x, 0, 0));
    s.frame_poses.push_back(fp);
  }
  return s;
}

TEST(MapExport, OverlapFramesComeFromTheEarlierSubmapAndDisconnectedAreLeftOut) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "glam_map_export_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "submaps");
  Submap s0 = FrameOnlySubmap(0, 0, 9, 1.0);
  Submap s1 = FrameOnlySubmap(1, 8, 15, 2.0);
  Submap s2 = FrameOnlySubmap(2, 20, 24, 5.0);
  Landmark lm;
  lm.point_in_submap = {1, 2, 3};
  lm.color = {10, 20, 30};
  s1.landmarks.push_back(lm);
  s2.landmarks.push_back(lm);
  for (const Submap* s : {&s0, &s1, &s2}) WriteSubmap(*s, dir / "submaps");
  MapSnapshot snapshot;
  snapshot.revision = 3;
  const Sim3 world_from_s1(2.0, SO3(), Eigen::Vector3d(0, 0, 1));
  snapshot.submaps = {{0, Sim3(), false, 0, 9}, {1, world_from_s1, false, 8, 15}, {2, Sim3(), true, 20, 24}};
  const MapExportCounts counts = ExportWorldMap(snapshot, dir / "submaps", dir, 10.0);
  EXPECT_EQ(counts.frames_posed, 16);
  EXPECT_EQ(counts.points, 1);
  EXPECT_EQ(counts.submaps_exported, 2);
  const std::vector<TimedPose> poses = ReadTumTrajectory(dir / "trajectory.tum");
  ASSERT_EQ(poses.size(), 16u);
  EXPECT_NEAR(poses[8].timestamp, 0.8, 1e-12);
  EXPECT_NEAR(poses[8].world_from_cam.translation().x(), 1.0, 1e-9);   // from submap 0
  EXPECT_NEAR(poses[10].world_from_cam.translation().x(), 4.0, 1e-9);  // 2 x 2.0 from submap 1
  const std::vector<ColoredPoint> points = ReadPlyPoints(dir / "points.ply");
  ASSERT_EQ(points.size(), 1u);
  EXPECT_NEAR(points[0].position.z(), 7.0f, 1e-5);  // 2 x 3 + 1
  EXPECT_EQ(points[0].color[2], 30);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace glam
