#include "engine/core/placed_pose.h"

namespace glam {

SE3 WorldFromCam(const Sim3& world_from_submap, const SE3& cam_from_submap) {
  const SE3 submap_from_cam = cam_from_submap.Inverse();
  return SE3(world_from_submap.rotation() * submap_from_cam.rotation(),
             world_from_submap * submap_from_cam.translation());
}

SE3 CamFromWorld(const Sim3& world_from_submap, const SE3& cam_from_submap) {
  const SO3 rotation = cam_from_submap.rotation() * world_from_submap.rotation().Inverse();
  return SE3(rotation, world_from_submap.scale() * cam_from_submap.translation() -
                           (rotation * world_from_submap.translation()));
}

SE3 CamFromSubmap(const Sim3& world_from_submap, const SE3& cam_from_world) {
  return SE3(cam_from_world.rotation() * world_from_submap.rotation(),
             (cam_from_world.rotation() * world_from_submap.translation() + cam_from_world.translation()) /
                 world_from_submap.scale());
}

}  // namespace glam
