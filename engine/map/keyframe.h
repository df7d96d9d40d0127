// Keyframes and per-frame poses of a submap. Poses are stored as cam_from_submap (the
// direction bundle adjustment and PnP work in); world poses are derived by composing with the
// submap's world_from_submap, which only global alignment changes.
#pragma once

#include <cstdint>
#include <vector>

#include "engine/core/median.h"
#include "engine/core/se3.h"

namespace glam {

struct Keyframe {
  std::int64_t frame_index = 0;
  SE3 cam_from_submap;
  // Per-keyframe focal length as refined by bundle adjustment (pixels, processing size).
  double focal = 0;
};

// Upper median of the keyframes' focals (0 when there are none): where a shared focal starts,
// and what an adjusted copy of a submap settled on.
inline double MedianFocal(const std::vector<Keyframe>& keyframes) {
  std::vector<double> focals;
  focals.reserve(keyframes.size());
  for (const Keyframe& kf : keyframes) focals.push_back(kf.focal);
  return UpperMedian(std::move(focals));
}

// The pose of one video frame (keyframe or not) inside its submap, after relocalisation.
struct FramePose {
  std::int64_t frame_index = 0;
  double timestamp_s = 0;
  SE3 cam_from_submap;
  std::uint32_t pnp_inliers = 0;
};

}  // namespace glam
