// Georeferenced results are compared with the truth with no alignment at all (that is the
// point of georeferencing): a mapped camera centre plus `shift` (the true position at the ENU
// origin, i.e. the first GPS fix) against the true centre of the frame it shows.
#pragma once

#include <cstddef>
#include <functional>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "engine/export/tum_trajectory.h"

namespace glam::testing {

// truth_index(t): the index in `truth` of the frame a mapped pose with timestamp t shows, or
// nullopt to leave the pose out. Returns the rms distance (m); *count (optional) gets how
// many poses were compared. With none compared the rms is +inf, which fails any bound.
double UnalignedCentreRms(const std::vector<TimedPose>& mapped, const std::vector<TimedPose>& truth,
                          const Eigen::Vector3d& shift,
                          const std::function<std::optional<std::size_t>(double)>& truth_index,
                          std::size_t* count = nullptr);

// truth_index for a photo folder made of frames `frame_of_photo` of a clip: photo folders are
// mapped at 1 fps, so timestamp t is the photo's index, and its truth is that frame's.
std::function<std::optional<std::size_t>(double)> PhotoFrames(std::vector<std::size_t> frame_of_photo);

}  // namespace glam::testing
