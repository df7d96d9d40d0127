// Where the camera is expected at a frame's time, from the poses of frames before it: the
// prior that tracking's guided matching searches around (tracking.cc) and that the frames
// between the two bootstrap keyframes are localised from (bootstrap.cc).
//
// Why time, not frame count: frames do not always come at equal steps. A live stream drops
// frames when mapping falls behind or the link hiccups (their numbers are skipped, see
// StreamSource), and frames that tracking could not pose leave a gap between the last two
// posed frames and the one being tracked. A prediction that assumes one step of motion then
// lags by the missed steps; past the guided search radius (4 % of the image diagonal) tracking
// falls back to matching against every landmark, which costs 25-70 ms per frame and is the
// less reliable of the two on repetitive ground.
#pragma once

#include "engine/core/se3.h"

namespace glam {

// The camera's motion from `before` to `last` (cam_last_from_cam_before), continued at the
// same velocity (constant screw motion on SE(3)) up to `t_now`: cam_now_from_submap. Times in
// seconds. The step is scaled by (t_now - t_last) / (t_last - t_before), clamped to
// [0, kMaxExtrapolationSteps]; equal steps (ratio 1) give exactly
// cam_last_from_cam_before * cam_last_from_submap. Non-increasing or non-finite times count
// as one step.
SE3 ExtrapolateConstantVelocity(const SE3& cam_before_from_submap, double t_before,
                                const SE3& cam_last_from_submap, double t_last, double t_now);

// Beyond this many steps of the last motion a constant velocity says little (a turn, a stop):
// the prediction stops there and guided matching, or the fallback, does the rest.
inline constexpr double kMaxExtrapolationSteps = 8.0;

}  // namespace glam
