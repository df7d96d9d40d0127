#include "tests/support/unaligned_error.h"

#include <cmath>
#include <limits>

namespace glam::testing {

double UnalignedCentreRms(const std::vector<TimedPose>& mapped, const std::vector<TimedPose>& truth,
                          const Eigen::Vector3d& shift,
                          const std::function<std::optional<std::size_t>(double)>& truth_index,
                          std::size_t* count) {
  double sum = 0;
  std::size_t n = 0;
  for (const TimedPose& p : mapped) {
    const std::optional<std::size_t> index = truth_index(p.timestamp);
    if (!index || *index >= truth.size()) continue;
    sum += (p.world_from_cam.translation() + shift - truth[*index].world_from_cam.translation()).squaredNorm();
    ++n;
  }
  if (count != nullptr) *count = n;
  return n > 0 ? std::sqrt(sum / static_cast<double>(n)) : std::numeric_limits<double>::infinity();
}

std::function<std::optional<std::size_t>(double)> PhotoFrames(std::vector<std::size_t> frame_of_photo) {
  return [frames = std::move(frame_of_photo)](double t) -> std::optional<std::size_t> {
    const long long photo = std::llround(t);
    if (photo < 0 || static_cast<std::size_t>(photo) >= frames.size()) return std::nullopt;
    return frames[static_cast<std::size_t>(photo)];
  };
}

}  // namespace glam::testing
