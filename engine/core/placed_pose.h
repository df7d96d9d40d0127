// Poses of a camera posed in a submap, seen from the world the submap is placed in. Submaps
// have their own origin AND scale (monocular), so a submap's placement is a Sim3
// (world_from_submap), while a camera pose stays an SE3: in the world frame the submap's scale
// is folded into the translation (the camera's world position is the Sim3 applied to its
// centre). Shared by the map export (world trajectories) and the global refinement (world
// cameras and back).
#pragma once

#include "engine/core/se3.h"
#include "engine/core/sim3.h"

namespace glam {

// world_from_cam of a camera with cam_from_submap: rotation R_world_from_submap *
// R_submap_from_cam, translation the Sim3 applied to the camera centre.
SE3 WorldFromCam(const Sim3& world_from_submap, const SE3& cam_from_submap);

// The inverse of WorldFromCam.
SE3 CamFromWorld(const Sim3& world_from_submap, const SE3& cam_from_submap);

// Back into the submap's own units: cam_from_submap of a camera whose world pose is
// cam_from_world (CamFromSubmap(w, CamFromWorld(w, p)) == p).
SE3 CamFromSubmap(const Sim3& world_from_submap, const SE3& cam_from_world);

}  // namespace glam
