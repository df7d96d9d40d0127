// The world frame is the first submap's frame, levelled (Contracts: z up, the fitted ground
// plane is z = const and the flight is above it). Monocular submaps start at an arbitrary
// camera orientation, so without this a tilted first frame would tilt the whole map in the
// viewer and in every export. The ground plane is fitted robustly (RANSAC on landmark
// triples, least-squares refit on inliers) because buildings and trees stick out of it.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "engine/core/sim3.h"
#include "engine/map/submap.h"

namespace glam {

struct LevelingOptions {
  // Plane inlier distance as a fraction of the median camera-to-point distance.
  double inlier_fraction = 0.03;
  int iterations = 300;
  unsigned seed = 7;

  void Check() const;  // throws InputError
};

struct LevelingResult {
  bool levelled = false;  // false: too few points, identity returned
  // Rotation taking the plane normal to +z (cameras on the +z side), translation putting the
  // first camera at x = y = 0 and the ground plane at z = 0. Scale 1.
  Sim3 world_from_submap;
  int plane_inliers = 0;
};

LevelingResult LevelGround(const std::vector<Eigen::Vector3d>& points,
                           const std::vector<Eigen::Vector3d>& camera_centres,
                           const LevelingOptions& options = {});

// Convenience: landmarks and keyframe centres of a submap.
LevelingResult LevelSubmap(const Submap& submap, const LevelingOptions& options = {});

// The frame of a part of the map (submaps placed relative to each other, in `part` units), as
// the world frame is built: `first`, the part's first submap, levelled. part_from_first: where
// that submap sits in the part. Returns levelled_from_part.
Sim3 LevelPart(const Submap& first, const Sim3& part_from_first, const LevelingOptions& options = {});

}  // namespace glam
