// Submaps that hold frame poses only (no keyframes, no landmarks), for tests of what is made
// from poses: the whole-map trajectory, the GPS fit of live revisions.
#pragma once

#include <cstdint>
#include <functional>

#include <Eigen/Core>

#include "engine/map/submap.h"

namespace glam::testing {

// Frames [first, last], each camera at centre_in_submap(frame index) with the identity
// rotation (cam_from_submap = [I | -centre]); pnp_inliers 0 (as a rotation-only pose).
inline Submap PosedSubmap(std::uint32_t id, std::int64_t first, std::int64_t last,
                          const std::function<Eigen::Vector3d(std::int64_t)>& centre_in_submap) {
  Submap s;
  s.id = id;
  s.first_frame = first;
  s.last_frame = last;
  for (std::int64_t i = first; i <= last; ++i) {
    FramePose fp;
    fp.frame_index = i;
    fp.cam_from_submap = SE3(SO3(), -centre_in_submap(i));
    s.frame_poses.push_back(fp);
  }
  return s;
}

}  // namespace glam::testing
