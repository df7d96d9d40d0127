#include "engine/features/epipolar_matcher.h"

#include <cmath>
#include <limits>

#include "engine/core/error.h"
#include "engine/core/options.h"
#include "engine/core/so3.h"
#include "engine/features/guided_matcher.h"

namespace glam {

void EpipolarMatchOptions::Check() const {
  CheckGreater("EpipolarMatchOptions.max_line_distance_px", max_line_distance_px, 0.0);
  CheckInRange("EpipolarMatchOptions.ratio", ratio, 0.05f, 1.0f);
}

std::vector<Match> MatchAlongEpipolarLines(const cv::Mat& query_descriptors,
                                           const std::vector<Eigen::Vector2d>& query_normalised,
                                           const cv::Mat& train_descriptors,
                                           const std::vector<Eigen::Vector2d>& train_normalised,
                                           const SE3& cam_train_from_cam_query, double focal_px,
                                           const EpipolarMatchOptions& options) {
  options.Check();
  CheckGreater("MatchAlongEpipolarLines focal_px", focal_px, 0.0);
  GLAM_CHECK(static_cast<std::size_t>(query_descriptors.rows) == query_normalised.size(),
             "{} query descriptors but {} query points", query_descriptors.rows, query_normalised.size());
  GLAM_CHECK(static_cast<std::size_t>(train_descriptors.rows) == train_normalised.size(),
             "{} train descriptors but {} train points", train_descriptors.rows, train_normalised.size());
  std::vector<Match> matches;
  if (query_descriptors.rows == 0 || train_descriptors.rows == 0) return matches;
  GLAM_CHECK(query_descriptors.type() == CV_32F && train_descriptors.type() == CV_32F &&
                 query_descriptors.cols == train_descriptors.cols,
             "descriptors must be CV_32F rows of equal length");
  const double baseline = cam_train_from_cam_query.translation().norm();
  if (!(baseline > 0)) return matches;

  // x_train = R x_query + t; a query ray's points project onto the line E x_query with
  // E = [t]x R (t scaled to unit length: only directions matter).
  const Eigen::Matrix3d R = cam_train_from_cam_query.rotation().matrix();
  const Eigen::Vector3d t = cam_train_from_cam_query.translation() / baseline;
  const Eigen::Matrix3d E = Hat(t) * R;
  const double max_distance = options.max_line_distance_px / focal_px;
  const int dim = query_descriptors.cols;
  const float ratio2 = options.ratio * options.ratio;

  // Per train feature: the closest query among the pairs compared (for the mutual check).
  std::vector<float> train_best(train_normalised.size(), std::numeric_limits<float>::infinity());
  std::vector<int> train_best_query(train_normalised.size(), -1);
  for (int q = 0; q < query_descriptors.rows; ++q) {
    const Eigen::Vector3d ray(query_normalised[static_cast<std::size_t>(q)].x(),
                              query_normalised[static_cast<std::size_t>(q)].y(), 1.0);
    const Eigen::Vector3d line = E * ray;
    const double line_norm = std::hypot(line.x(), line.y());
    if (!(line_norm > 1e-12)) continue;  // the query sits on the epipole: no line
    const double a = line.x() / line_norm, b = line.y() / line_norm, c = line.z() / line_norm;
    const Eigen::Vector3d rotated_ray = R * ray;
    const float* qd = query_descriptors.ptr<float>(q);
    float best = std::numeric_limits<float>::infinity(), second = best;
    int best_index = -1;
    for (std::size_t j = 0; j < train_normalised.size(); ++j) {
      const Eigen::Vector2d& x = train_normalised[j];
      if (std::abs(a * x.x() + b * x.y() + c) > max_distance) continue;
      // In front of both cameras: d_train x_train = d_query R x_query + t with both depths > 0.
      const Eigen::Vector3d train_ray(x.x(), x.y(), 1.0);
      const Eigen::Vector3d cross = train_ray.cross(rotated_ray);
      const double depth_query = -train_ray.cross(t).dot(cross);
      const double depth_train = t.cross(rotated_ray).dot(cross);
      if (depth_query <= 0 || depth_train <= 0) continue;
      const float d = DescriptorDistanceSquared(qd, train_descriptors.ptr<float>(static_cast<int>(j)), dim);
      if (d < best) {
        second = best;
        best = d;
        best_index = static_cast<int>(j);
      } else if (d < second) {
        second = d;
      }
      if (d < train_best[j]) {
        train_best[j] = d;
        train_best_query[j] = q;
      }
    }
    if (best_index < 0) continue;
    if (!std::isfinite(second)) {
      if (!options.accept_lone_candidate) continue;
    } else if (options.ratio < 1.0f && !(best < ratio2 * second)) {
      continue;
    }
    matches.push_back({q, best_index, std::sqrt(best)});
  }
  if (!options.mutual) return matches;
  std::vector<Match> mutual;
  mutual.reserve(matches.size());
  for (const Match& m : matches) {
    if (train_best_query[static_cast<std::size_t>(m.train)] == m.query) mutual.push_back(m);
  }
  return mutual;
}

}  // namespace glam
