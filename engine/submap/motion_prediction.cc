#include "engine/submap/motion_prediction.h"

#include <algorithm>
#include <cmath>

namespace glam {

SE3 ExtrapolateConstantVelocity(const SE3& cam_before_from_submap, double t_before,
                                const SE3& cam_last_from_submap, double t_last, double t_now) {
  const SE3 cam_last_from_cam_before = cam_last_from_submap * cam_before_from_submap.Inverse();
  const double step = t_last - t_before;
  double steps = 1.0;
  if (std::isfinite(step) && std::isfinite(t_now) && step > 0) {
    steps = std::clamp((t_now - t_last) / step, 0.0, kMaxExtrapolationSteps);
  }
  // Equal steps, the common case, stay the plain product (no Log/Exp round trip).
  if (std::abs(steps - 1.0) < 1e-9) return cam_last_from_cam_before * cam_last_from_submap;
  return SE3::Exp(steps * cam_last_from_cam_before.Log()) * cam_last_from_submap;
}

}  // namespace glam
