// Poses of a camera posed in a placed submap (engine/core/placed_pose.h) against their
// definitions: the camera centre goes through the Sim3, viewing rays through its rotation, and
// the three functions are each other's inverses.
#include <gtest/gtest.h>

#include "engine/core/placed_pose.h"

namespace glam {
namespace {

TEST(PlacedPose, WorldFromCamComposesSim3AndCameraPose) {
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

TEST(PlacedPose, CamFromWorldAndCamFromSubmapAreTheInverses) {
  const Sim3 world_from_submap(0.4, SO3::Exp(Eigen::Vector3d(-0.7, 0.3, 2.1)), Eigen::Vector3d(-8, 2, 30));
  const SE3 cam_from_submap(SO3::Exp(Eigen::Vector3d(0.5, -0.1, 1.2)), Eigen::Vector3d(0.3, 4, -1));
  const SE3 cam_from_world = CamFromWorld(world_from_submap, cam_from_submap);
  const SE3 identity = cam_from_world * WorldFromCam(world_from_submap, cam_from_submap);
  EXPECT_LT(identity.rotation().Log().norm(), 1e-12);
  EXPECT_LT(identity.translation().norm(), 1e-12);
  const SE3 back = CamFromSubmap(world_from_submap, cam_from_world);
  EXPECT_LT((back.rotation().Inverse() * cam_from_submap.rotation()).Log().norm(), 1e-12);
  EXPECT_LT((back.translation() - cam_from_submap.translation()).norm(), 1e-12);
  // A submap point seen in the camera: the same direction from the world pose, at s times the depth.
  const Eigen::Vector3d p_submap(2, -1, 9);
  const Eigen::Vector3d seen = cam_from_submap * p_submap;
  EXPECT_LT((cam_from_world * (world_from_submap * p_submap) - world_from_submap.scale() * seen).norm(), 1e-9);
}

}  // namespace
}  // namespace glam
