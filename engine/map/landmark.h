// A 3D point of a submap. Descriptors are kept as 128 bytes (SIFT values are 0..255 after
// OpenCV's normalisation): a quarter of the float size, which is what keeps thousands of
// submaps of a long flight affordable on disk and in the aligner's on-demand loads.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace glam {

inline constexpr int kDescriptorSize = 128;
using Descriptor = std::array<std::uint8_t, kDescriptorSize>;
using Rgb = std::array<std::uint8_t, 3>;

struct Observation {
  std::uint32_t keyframe = 0;  // index into Submap::keyframes
  Eigen::Vector2f pixel{0, 0};  // processing-size pixel coordinates
};

struct Landmark {
  // Unique within its submap and stable while filters remove other landmarks, so per-frame
  // 2D-3D matches can refer to it.
  std::uint32_t id = 0;
  Eigen::Vector3d point_in_submap{0, 0, 0};
  Rgb color{0, 0, 0};
  Descriptor descriptor{};
  std::vector<Observation> observations;
};

}  // namespace glam
