// Relative pose of two calibrated views (bootstrapping a submap, new keyframe pairs): the
// five-point essential matrix (Nister 2004, OpenCV's solver applied to each minimal sample)
// inside glam::Ransac, a nonlinear (Sampson) refit on the inliers, and the cheirality test
// that picks the one of four (R, t) decompositions placing the points in front of both cameras.
// Observations are normalised image coordinates; residuals are Sampson distances in pixels
// through focal_px. Convention: x2^T E x1 = 0 with E = [t]x R and x2 ~ R x1 + t, so
// (R, t) is cam2_from_cam1; |t| = 1 (scale is unobservable).
#pragma once

#include <span>
#include <vector>

#include <Eigen/Core>

#include "engine/core/se3.h"
#include "engine/geometry/ransac.h"

namespace glam {

struct TwoViewCorrespondence {
  Eigen::Vector2d x1;  // normalised, view 1
  Eigen::Vector2d x2;  // normalised, view 2
};

class EssentialEstimator {
 public:
  using Datum = TwoViewCorrespondence;
  using Model = Eigen::Matrix3d;
  static constexpr int kMinSampleSize = 5;

  explicit EssentialEstimator(double focal_px) : focal_px_(focal_px) {}

  // Up to 10 essential matrices (the real roots of the five-point polynomial).
  std::vector<Eigen::Matrix3d> Fit(std::span<const Datum> sample) const;
  // Sampson distance in pixels.
  double Residual(const Eigen::Matrix3d& E, const Datum& d) const;
  // Levenberg-Marquardt on the inliers' Sampson distances over (R, t/|t|). Ransac keeps the
  // result only if it lowers the MSAC cost.
  bool Refine(std::span<const Datum> inliers, Eigen::Matrix3d* E) const;

 private:
  double focal_px_;
};

struct RelativePose {
  SE3 cam2_from_cam1;                 // |translation| = 1
  std::vector<uint8_t> inlier_mask;   // input mask AND in front of both cameras
  int num_inliers = 0;
};

// Chooses among the four decompositions of E by cheirality over the masked correspondences.
// Points farther than max_depth baselines from camera 1 (near-parallel rays) do not vote and
// are dropped from the mask, as in cv::recoverPose.
RelativePose RecoverRelativePose(const Eigen::Matrix3d& E,
                                 std::span<const TwoViewCorrespondence> data,
                                 const std::vector<uint8_t>& mask, double max_depth = 50.0);

struct RelativePoseResult {
  bool success = false;
  Eigen::Matrix3d essential = Eigen::Matrix3d::Zero();
  SE3 cam2_from_cam1;
  std::vector<uint8_t> inlier_mask;  // RANSAC inliers that also pass cheirality
  int num_inliers = 0;
  int iterations = 0;
};

// RANSAC essential matrix + RecoverRelativePose. options.inlier_threshold in pixels.
// success requires options.min_inliers (and 5) inliers after cheirality.
// max_depth as in RecoverRelativePose: raise it where small baselines are expected (a
// bootstrap watching parallax grow decides on triangulation angles itself).
RelativePoseResult EstimateRelativePose(std::span<const TwoViewCorrespondence> data,
                                        double focal_px, const RansacOptions& options,
                                        double max_depth = 50.0);

}  // namespace glam
