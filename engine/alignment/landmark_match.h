// One verified correspondence between two submaps: landmark_a of submap a and landmark_b of
// submap b are the same ground point, each given in its own submap frame. Pair verification
// (submap_verifier.h, a = the reference submap, b = the query) produces them and the submap
// factor graph (submap_graph.h) consumes them, so both speak this one type. Temporal edges
// also carry pairs made from the frames both submaps posed (shared_frames.h): their ids lie
// in a reserved range above every landmark id, so they key graph nodes like landmarks do.
#pragma once

#include <cstdint>

#include <Eigen/Core>

namespace glam {

struct LandmarkMatch {
  std::uint32_t landmark_a = 0;  // Landmark::id in submap a
  std::uint32_t landmark_b = 0;  // Landmark::id in submap b
  Eigen::Vector3d point_in_a{0, 0, 0};
  Eigen::Vector3d point_in_b{0, 0, 0};
};

// One member of a landmark matched across submaps: Landmark::id `landmark` of submap `submap`
// (SubmapAligner::LandmarkGroups, global_refinement.h).
struct LandmarkKey {
  std::uint32_t submap = 0;
  std::uint32_t landmark = 0;
};

}  // namespace glam
