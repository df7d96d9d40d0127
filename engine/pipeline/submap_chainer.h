// Links consecutive submaps before global alignment exists: the next submap starts inside the
// previous one's last 10 % of frames (see Contracts), so both triangulated the same ground.
// Their landmarks are matched by descriptor and the relative similarity prev_from_new is
// found by Sim3 RANSAC on the 3D-3D correspondences (monocular submaps differ in scale too).
// The inlier threshold is relative to the previous submap's own scale (median distance of its
// landmarks to the nearest keyframe centre, i.e. roughly the flying height in submap units),
// because submap units are arbitrary.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "engine/core/sim3.h"
#include "engine/map/submap.h"

namespace glam {

struct ChainingOptions {
  float match_ratio = 0.8f;        // Lowe's ratio test on landmark descriptors
  bool mutual = true;              // cross-checked matches only
  // RANSAC inlier threshold = this x SubmapScale(previous).
  double inlier_threshold_fraction = 0.02;
  int min_inliers = 15;            // fewer -> the submaps are not linked
  double min_inlier_ratio = 0.2;   // inliers / matches below this -> not linked
  int max_iterations = 1000;
  double confidence = 0.999;
  unsigned seed = 1;

  void Check() const;  // throws InputError
};

struct ChainResult {
  bool linked = false;
  Sim3 prev_from_new;  // identity when !linked
  int matches = 0;
  int inliers = 0;
  double inlier_rmse = 0;  // in the previous submap's units
};

// Median over landmarks of the distance to the nearest keyframe centre; 1 if undefined.
double SubmapScale(const Submap& submap);

// Matches the two submaps' landmarks and verifies them with Sim3 RANSAC (the project's RANSAC
// template with the similarity estimator of engine/geometry).
ChainResult LinkSubmaps(const Submap& previous, const Submap& next,
                        const ChainingOptions& options = {});

}  // namespace glam
