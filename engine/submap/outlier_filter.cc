// Standalone FLANN must be included before anything that pulls in OpenCV's bundled flann.
#include <flann/flann.hpp>

#include "engine/submap/outlier_filter.h"

#include <algorithm>
#include <cmath>

#include "engine/core/options.h"
#include "engine/geometry/triangulation.h"
#include "engine/submap/bundle_adjuster.h"

namespace glam {

void OutlierFilterOptions::Check() const {
  CheckGreater("OutlierFilterOptions.max_reprojection_pixels", max_reprojection_pixels, 0.0);
  CheckGreaterEqual("OutlierFilterOptions.min_observations", min_observations, 2);
  CheckGreater("OutlierFilterOptions.neighbours", neighbours, 0);
  CheckGreater("OutlierFilterOptions.max_std_devs", max_std_devs, 0.0);
  CheckInRange("OutlierFilterOptions.min_completion_angle_deg", min_completion_angle_deg, 0.0, 90.0);
}

std::size_t RemoveWeaklyTriangulatedLandmarks(const std::vector<Keyframe>& keyframes,
                                              std::vector<Landmark>& landmarks,
                                              const OutlierFilterOptions& options) {
  if (options.min_completion_angle_deg <= 0) return 0;
  const double min_angle = options.min_completion_angle_deg * M_PI / 180.0;
  std::vector<Eigen::Vector3d> centres;
  centres.reserve(keyframes.size());
  for (const Keyframe& kf : keyframes) centres.push_back(CameraCenter(kf.cam_from_submap));
  const std::size_t before = landmarks.size();
  std::erase_if(landmarks, [&](const Landmark& lm) {
    const std::vector<Observation>& obs = lm.observations;
    for (std::size_t a = 0; a < obs.size(); ++a) {
      for (std::size_t b = a + 1; b < obs.size(); ++b) {
        const double angle =
            TriangulationAngle(centres[obs[a].keyframe], centres[obs[b].keyframe], lm.point_in_submap);
        if (angle >= min_angle) return false;  // wide enough
      }
    }
    return true;
  });
  return before - landmarks.size();
}

std::size_t RemoveReprojectionOutliers(const Intrinsics& intrinsics,
                                       const std::vector<Keyframe>& keyframes,
                                       std::vector<Landmark>& landmarks,
                                       const OutlierFilterOptions& options) {
  const std::size_t before = landmarks.size();
  for (Landmark& lm : landmarks) {
    std::erase_if(lm.observations, [&](const Observation& obs) {
      return ReprojectionError(intrinsics, keyframes[obs.keyframe], lm.point_in_submap, obs.pixel) >
             options.max_reprojection_pixels;
    });
  }
  std::erase_if(landmarks, [&](const Landmark& lm) {
    return static_cast<int>(lm.observations.size()) < options.min_observations;
  });
  return before - landmarks.size();
}

std::vector<double> MeanNeighbourDistances(const std::vector<Eigen::Vector3d>& points, int k) {
  const std::size_t n = points.size();
  std::vector<double> mean(n, 0.0);
  if (n < 2) return mean;
  const int kk = std::min<int>(k + 1, static_cast<int>(n));  // +1: the point finds itself
  std::vector<float> data(n * 3);
  for (std::size_t i = 0; i < n; ++i) {
    for (int d = 0; d < 3; ++d) data[i * 3 + d] = static_cast<float>(points[i][d]);
  }
  flann::Matrix<float> dataset(data.data(), n, 3);
  flann::Index<flann::L2<float>> index(dataset, flann::KDTreeSingleIndexParams(12));
  index.buildIndex();
  std::vector<int> indices(n * kk);
  std::vector<float> dists(n * kk);
  flann::Matrix<int> idx(indices.data(), n, kk);
  flann::Matrix<float> dst(dists.data(), n, kk);
  flann::SearchParams params;
  params.checks = flann::FLANN_CHECKS_UNLIMITED;
  index.knnSearch(dataset, idx, dst, kk, params);
  for (std::size_t i = 0; i < n; ++i) {
    double sum = 0;
    int count = 0;
    for (int j = 0; j < kk; ++j) {
      if (static_cast<std::size_t>(idx[i][j]) == i) continue;
      sum += std::sqrt(static_cast<double>(dst[i][j]));  // FLANN's L2 returns squared distances
      ++count;
    }
    mean[i] = count > 0 ? sum / count : 0.0;
  }
  return mean;
}

std::size_t RemoveIsolatedLandmarks(std::vector<Landmark>& landmarks, const OutlierFilterOptions& options,
                                    std::uint32_t first_tested_id) {
  if (static_cast<int>(landmarks.size()) <= options.neighbours) return 0;
  std::vector<Eigen::Vector3d> points;
  points.reserve(landmarks.size());
  for (const Landmark& lm : landmarks) points.push_back(lm.point_in_submap);
  const std::vector<double> mean = MeanNeighbourDistances(points, options.neighbours);

  double mu = 0;
  for (double m : mean) mu += m;
  mu /= static_cast<double>(mean.size());
  double var = 0;
  for (double m : mean) var += (m - mu) * (m - mu);
  const double sigma = std::sqrt(var / static_cast<double>(mean.size()));
  const double limit = mu + options.max_std_devs * sigma;

  std::size_t i = 0;
  const std::size_t before = landmarks.size();
  std::erase_if(landmarks, [&](const Landmark& lm) { return mean[i++] > limit && lm.id >= first_tested_id; });
  return before - landmarks.size();
}

}  // namespace glam
