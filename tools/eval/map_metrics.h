// Map accuracy: distance of the estimated points, brought into the ground-truth frame by the
// trajectory alignment, to the true surface. Using the trajectory's alignment (not a fit of
// the cloud to the surface) means a map is only good if it is consistent with its own
// camera poses, which is what a user of the map relies on.
#pragma once

#include <cstddef>
#include <vector>

#include "engine/core/sim3.h"
#include "engine/export/ply_points.h"
#include "tools/eval/ground_truth_surface.h"

namespace glam::eval {

struct MapMetrics {
  std::size_t points = 0;     // points in the cloud
  std::size_t evaluated = 0;  // points over the ground-truth footprint (scored)
  std::size_t outside = 0;    // points outside the footprint or non-finite (not scored)
  // Over the evaluated points, metres; all zero when none was evaluated.
  double rmse = 0;
  double mean = 0;
  double median = 0;
  double within_0_5m = 0;  // share of evaluated points closer than 0.5 m
  double within_1m = 0;    // share of evaluated points closer than 1 m
};

// `max_search_radius` bounds the exact-distance search (HeightfieldSurface::Distance):
// farther points get an upper bound >= it, which only matters for gross outliers.
MapMetrics EvaluateMap(const std::vector<ColoredPoint>& points, const Sim3& gt_from_estimate,
                       const HeightfieldSurface& surface, double max_search_radius = 50.0);

}  // namespace glam::eval
