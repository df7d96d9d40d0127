#include "tools/eval/map_metrics.h"

#include <algorithm>
#include <cmath>

namespace glam::eval {

MapMetrics EvaluateMap(const std::vector<ColoredPoint>& points, const Sim3& gt_from_estimate,
                       const HeightfieldSurface& surface, double max_search_radius) {
  MapMetrics m;
  m.points = points.size();
  std::vector<double> distances;
  distances.reserve(points.size());
  for (const ColoredPoint& p : points) {
    const Eigen::Vector3d point_in_gt = gt_from_estimate * p.position.cast<double>();
    const SurfaceDistance d = surface.Distance(point_in_gt, max_search_radius);
    if (d.inside) distances.push_back(d.distance);
  }
  m.evaluated = distances.size();
  m.outside = m.points - m.evaluated;
  if (distances.empty()) return m;

  double sum = 0, sum_sq = 0;
  std::size_t within_half = 0, within_one = 0;
  for (double d : distances) {
    sum += d;
    sum_sq += d * d;
    within_half += d < 0.5 ? 1 : 0;
    within_one += d < 1.0 ? 1 : 0;
  }
  const double n = static_cast<double>(distances.size());
  m.rmse = std::sqrt(sum_sq / n);
  m.mean = sum / n;
  m.within_0_5m = static_cast<double>(within_half) / n;
  m.within_1m = static_cast<double>(within_one) / n;
  const std::size_t mid = distances.size() / 2;
  std::nth_element(distances.begin(), distances.begin() + static_cast<std::ptrdiff_t>(mid),
                   distances.end());
  m.median = distances[mid];
  if (distances.size() % 2 == 0) {
    m.median =
        0.5 * (m.median + *std::max_element(distances.begin(),
                                            distances.begin() + static_cast<std::ptrdiff_t>(mid)));
  }
  return m;
}

}  // namespace glam::eval
