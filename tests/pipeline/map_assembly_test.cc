// World poses written to trajectory.tum: world_from_cam composed from world_from_submap (Sim3)
// and cam_from_submap (SE3), with scale acting on the position only.
#include "engine/pipeline/map_assembly.h"

#include <gtest/gtest.h>

#include "engine/export/tum_trajectory.h"

namespace glam {
namespace {

TEST(MapAssembly, WorldFromCamComposesSim3AndCameraPose) {
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

TEST(MapAssembly, OverlapFramesComeFromTheEarlierSubmapAndUnlinkableIsDisconnected) {
  MapAssembler assembler(VerificationOptions{}, LevelingOptions{});
  assembler.Add(FrameOnlySubmap(0, 0, 9, 1.0));   // no landmarks: identity world frame
  assembler.Add(FrameOnlySubmap(1, 8, 15, 2.0));  // cannot be linked (no landmarks)
  ASSERT_EQ(assembler.nodes().size(), 2u);
  EXPECT_FALSE(assembler.nodes()[0].disconnected);
  EXPECT_TRUE(assembler.nodes()[1].disconnected);
  EXPECT_EQ(assembler.disconnected(), 1);
  EXPECT_TRUE(assembler.edges().empty());
  EXPECT_EQ(assembler.frames_posed(), 16);
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / "glam_map_assembly_test_trajectory.tum";
  assembler.WriteTrajectory(path, 10.0);
  const std::vector<TimedPose> poses = ReadTumTrajectory(path);
  ASSERT_EQ(poses.size(), 16u);
  EXPECT_NEAR(poses[8].timestamp, 0.8, 1e-12);
  EXPECT_NEAR(poses[8].world_from_cam.translation().x(), 1.0, 1e-9);   // from submap 0
  EXPECT_NEAR(poses[10].world_from_cam.translation().x(), 2.0, 1e-9);  // from submap 1
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace glam
