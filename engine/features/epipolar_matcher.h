// Matching between two views whose relative pose is known: each query feature is compared only
// with the train features near its epipolar line (the line the query's ray projects to in the
// train view), with Lowe's ratio test among those candidates and a mutual check.
//
// Why: the submap builder triangulates new landmarks between two keyframes that PnP has
// already posed. Matching their unmatched features globally (2-nearest-neighbour search over
// ~1500 x 1500 descriptors, then an essential-matrix RANSAC to drop the matches the poses
// cannot explain) took ~45 ms per keyframe pair, a sixth of the submap builder thread on the
// loop benchmark video. A feature's match can only lie on its epipolar line, a band of a few
// pixels that holds ~1 % of the other view's features, so the candidates are found by a cheap
// point-line test and only those descriptors are compared (COLMAP's "guided matching" with a
// known geometry does the same). The ratio test is then taken among candidates that fit the
// geometry. Measured on the four COLMAP-benchmark videos against global matching + RANSAC
// (docs/benchmarks.md): 2.2 s -> 0.2 s of matching on the loop video, 5-23 % more landmarks,
// ATE lower on the oblique and compressed videos (0.071 -> 0.048 m, 0.160 -> 0.150 m), within
// 0.004 m on the other two. Only with a calibration (SubmapOptions).
#pragma once

#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "engine/core/se3.h"
#include "engine/features/feature_matcher.h"

namespace glam {

struct EpipolarMatchOptions {
  // A train feature is a candidate when it lies within this distance of the query's epipolar
  // line, in train-view pixels (focal_px converts it to normalised coordinates).
  double max_line_distance_px = 3.0;
  // Best < ratio * second best among the candidates. The band holds far fewer competitors than
  // the whole image, so a match is only as distinctive as a global one at a stricter ratio
  // (SubmapOptions::epipolar_match_ratio).
  float ratio = 0.7f;
  // A query with a single candidate has no second best to be compared with. Rejected by
  // default: its match would be unchecked, and any feature on the line triangulates to a
  // point consistent with both views.
  bool accept_lone_candidate = false;
  // Keep a match only if the query is also the best of the queries whose lines pass near the
  // train feature.
  bool mutual = true;

  void Check() const;  // throws InputError
};

// query_normalised[i] / train_normalised[j]: the features' normalised image coordinates (x / z,
// y / z of their rays, distortion removed) in their own camera; descriptors row i / j (CV_32F).
// cam_train_from_cam_query maps query-camera coordinates into the train camera. The views must
// have a baseline: with none (|t| == 0) there are no epipolar lines and nothing is matched.
// Returns matches sorted by query index, each train index at most once when mutual is set.
std::vector<Match> MatchAlongEpipolarLines(const cv::Mat& query_descriptors,
                                           const std::vector<Eigen::Vector2d>& query_normalised,
                                           const cv::Mat& train_descriptors,
                                           const std::vector<Eigen::Vector2d>& train_normalised,
                                           const SE3& cam_train_from_cam_query, double focal_px,
                                           const EpipolarMatchOptions& options = {});

}  // namespace glam
