// The paper's three outlier filters for submap landmarks:
//   1. after every BA: observations with reprojection error above a threshold are dropped,
//      and landmarks left with fewer than two observations go with them;
//   2. after every BA: points far from the rest of the scene (near-parallel rays give small
//      reprojection error but wild depth) — mean distance to the k = 30 nearest neighbours
//      (kd-tree) more than 2 standard deviations above the mean of that statistic (the submap
//      builder lets it remove only points it has not tested before: SubmapOptions::
//      isolated_filter_once);
//   3. at completion: both filters again, and points that are only weakly triangulated: the
//      largest angle between two of their keyframe rays is below min_completion_angle_deg.
//      Their depth error grows as 1 / angle (at 2 degrees and 0.3 px noise on a 550 px focal
//      it is ~1.5 % of the depth), and nothing later can improve them: the submap is frozen.
#pragma once

#include <cstddef>
#include <vector>

#include "engine/core/camera.h"
#include "engine/map/keyframe.h"
#include "engine/map/landmark.h"

namespace glam {

struct OutlierFilterOptions {
  double max_reprojection_pixels = 4.0;
  int min_observations = 2;
  int neighbours = 30;        // k of the paper
  double max_std_devs = 2.0;  // the paper's 2 sigma
  // Completion: minimum over-the-track triangulation angle (degrees; 0 = off). New points need
  // only 1 degree when created (so tracking has landmarks at once); the ones whose track never
  // widened beyond 2 degrees are the noisiest part of a finished submap (measured on the
  // synthetic lawnmower clip: median error 1.5 m below 2 degrees vs 0.2-0.5 m above).
  double min_completion_angle_deg = 2.0;

  void Check() const;
};

// Filter 1. Returns the number of landmarks removed.
std::size_t RemoveReprojectionOutliers(const Intrinsics& intrinsics,
                                       const std::vector<Keyframe>& keyframes,
                                       std::vector<Landmark>& landmarks,
                                       const OutlierFilterOptions& options);

// Filter 2. Returns the number of landmarks removed. With fewer than k + 1 points nothing is
// removed (the statistic is meaningless there). The statistic is taken over all landmarks, but
// only those with id >= first_tested_id can be removed (see SubmapBuilder::OptimiseAndFilter).
std::size_t RemoveIsolatedLandmarks(std::vector<Landmark>& landmarks, const OutlierFilterOptions& options,
                                    std::uint32_t first_tested_id = 0);

// Filter 3 (completion). Removes landmarks whose largest pairwise angle between the rays from
// their observing keyframes' centres is below options.min_completion_angle_deg; returns the
// number removed.
std::size_t RemoveWeaklyTriangulatedLandmarks(const std::vector<Keyframe>& keyframes,
                                              std::vector<Landmark>& landmarks,
                                              const OutlierFilterOptions& options);

// Mean distance of each point to its k nearest neighbours (itself excluded). Exposed for tests
// and for diagnostics.
std::vector<double> MeanNeighbourDistances(const std::vector<Eigen::Vector3d>& points, int k);

}  // namespace glam
