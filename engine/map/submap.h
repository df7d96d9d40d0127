// A completed submap: the unit thread 1 hands to thread 2 and the unit persisted to disk.
// Rigid after completion (see docs/architecture.md): alignment only changes the submap's
// world_from_submap, never its contents, so tiles and files written once stay valid.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "engine/core/camera.h"
#include "engine/map/keyframe.h"
#include "engine/map/landmark.h"

namespace glam {

struct SubmapStats {
  double build_seconds = 0;       // wall time of thread 1 on this submap
  double bundle_adjust_seconds = 0;
  std::uint32_t frames_unposed = 0;  // frames of the submap's range that PnP could not pose
  std::uint32_t landmarks_removed = 0;
};

struct Submap {
  std::uint32_t id = 0;
  // Frame index range [first_frame, last_frame] the submap covers (inclusive).
  std::int64_t first_frame = 0;
  std::int64_t last_frame = 0;
  // Camera model used for tracking; focal = median of the keyframes' refined focals.
  Intrinsics intrinsics;
  std::vector<Keyframe> keyframes;
  std::vector<Landmark> landmarks;
  std::vector<FramePose> frame_poses;
  SubmapStats stats;
};

}  // namespace glam
