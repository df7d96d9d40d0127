#include "engine/alignment/submap_verifier.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/core/median.h"
#include "engine/core/options.h"
#include "engine/features/feature_matcher.h"
#include "engine/geometry/similarity_ransac.h"
#include "engine/submap/frame_record.h"

namespace glam {

void VerificationOptions::Check() const {
  CheckInRange("VerificationOptions.match_ratio", match_ratio, 0.1f, 1.0f);
  CheckInRange("VerificationOptions.inlier_threshold_fraction", inlier_threshold_fraction, 1e-5, 1.0);
  CheckGreaterEqual("VerificationOptions.min_inliers", min_inliers, 3);
  CheckInRange("VerificationOptions.min_inlier_ratio", min_inlier_ratio, 0.0, 1.0);
  CheckGreaterEqual("VerificationOptions.max_rotation_sigma_deg", max_rotation_sigma_deg, 0.0);
  CheckGreater("VerificationOptions.max_iterations", max_iterations, 0);
  CheckInRange("VerificationOptions.confidence", confidence, 0.5, 0.999999);
}

double SubmapDepthScale(const Submap& submap) {
  if (submap.keyframes.empty() || submap.landmarks.empty()) return 1.0;
  std::vector<Eigen::Vector3d> centres;
  centres.reserve(submap.keyframes.size());
  for (const Keyframe& kf : submap.keyframes) {
    centres.push_back(kf.cam_from_submap.Inverse().translation());
  }
  std::vector<double> distances;
  distances.reserve(submap.landmarks.size());
  for (const Landmark& lm : submap.landmarks) {
    double best = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector3d& c : centres) best = std::min(best, (lm.point_in_submap - c).norm());
    distances.push_back(best);
  }
  const double median = UpperMedian(std::move(distances));
  return median > 0 && std::isfinite(median) ? median : 1.0;
}

namespace {

double RotationSigmaDeg(const std::vector<PointCorrespondence>& data, const std::vector<unsigned char>& inlier_mask,
                        double inlier_rmse) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  int n = 0;
  for (std::size_t i = 0; i < data.size(); ++i) {
    if (!inlier_mask[i]) continue;
    centroid += data[i].target;
    ++n;
  }
  if (n < 3) return std::numeric_limits<double>::infinity();
  centroid /= n;
  // Information of a small rotation about the centroid: sum of [q]x^T [q]x over the inliers,
  // q = point - centroid; with isotropic point noise sigma (per axis) the rotation's covariance is
  // sigma^2 * inverse(information), so its weakest direction has sigma / sqrt(lambda_min).
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < data.size(); ++i) {
    if (!inlier_mask[i]) continue;
    const Eigen::Vector3d q = data[i].target - centroid;
    information += q.squaredNorm() * Eigen::Matrix3d::Identity() - q * q.transpose();
  }
  const double lambda_min = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(information).eigenvalues()(0);
  if (!(lambda_min > 0)) return std::numeric_limits<double>::infinity();
  // inlier_rmse is the RMS of 3D residual norms: the per-axis noise is that over sqrt(3).
  const double sigma_per_axis = inlier_rmse / std::sqrt(3.0);
  return sigma_per_axis / std::sqrt(lambda_min) * 180.0 / M_PI;
}

}  // namespace

PairVerification VerifySubmapPair(const Submap& reference, const Submap& query,
                                  const VerificationOptions& options) {
  PairVerification out;
  if (reference.landmarks.size() < 3 || query.landmarks.size() < 3) return out;
  MatchOptions match_options;
  match_options.ratio = options.match_ratio;
  match_options.mutual = options.mutual;
  const std::vector<Match> matches =
      MatchDescriptors(LandmarkDescriptorMatrix(query.landmarks),
                       LandmarkDescriptorMatrix(reference.landmarks), match_options);
  out.matches = static_cast<int>(matches.size());
  std::vector<PointCorrespondence> data;
  data.reserve(matches.size());
  for (const Match& m : matches) {
    data.push_back({query.landmarks[static_cast<std::size_t>(m.query)].point_in_submap,
                    reference.landmarks[static_cast<std::size_t>(m.train)].point_in_submap});
  }
  const double threshold = options.inlier_threshold_fraction * SubmapDepthScale(reference);
  RansacOptions ransac_options;
  ransac_options.inlier_threshold = threshold;
  ransac_options.max_iterations = options.max_iterations;
  ransac_options.confidence = options.confidence;
  ransac_options.seed = options.seed;
  const RansacResult<Sim3> ransac = EstimateSimilarity(data, ransac_options);
  out.inliers = ransac.num_inliers;
  double sum_sq = 0;
  for (std::size_t i = 0; i < data.size(); ++i) {
    if (ransac.inlier_mask[i]) sum_sq += (ransac.model * data[i].source - data[i].target).squaredNorm();
  }
  out.inlier_rmse = out.inliers > 0 ? std::sqrt(sum_sq / out.inliers) : 0.0;
  out.rotation_sigma_deg = RotationSigmaDeg(data, ransac.inlier_mask, out.inlier_rmse);
  out.verified = ransac.success && out.inliers >= options.min_inliers &&
                 out.inliers >= options.min_inlier_ratio * out.matches &&
                 (options.max_rotation_sigma_deg <= 0 || out.rotation_sigma_deg <= options.max_rotation_sigma_deg);
  if (out.verified) {
    out.reference_from_query = ransac.model;
    out.inlier_pairs.reserve(static_cast<std::size_t>(out.inliers));
    for (std::size_t i = 0; i < data.size(); ++i) {
      if (!ransac.inlier_mask[i]) continue;
      const Landmark& r = reference.landmarks[static_cast<std::size_t>(matches[i].train)];
      const Landmark& q = query.landmarks[static_cast<std::size_t>(matches[i].query)];
      out.inlier_pairs.push_back({r.id, q.id, r.point_in_submap, q.point_in_submap});
    }
  }
  GLAM_LOG_DEBUG("verify submap {} against {}: {} matches, {} inliers, rmse {:.4g} (threshold {:.4g}), "
                 "rotation sigma {:.3f} deg{}",
                 query.id, reference.id, out.matches, out.inliers, out.inlier_rmse, threshold,
                 out.rotation_sigma_deg,
                 out.verified ? "" : ": rejected");
  return out;
}

}  // namespace glam
