// Relative pose of two calibrated views (bootstrapping a submap, new keyframe pairs): the
// five-point essential matrix (Nister 2004, OpenCV's solver applied to each minimal sample)
// inside glam::Ransac, a nonlinear (Sampson) refit on the inliers, and the cheirality test
// that picks the one of four (R, t) decompositions placing the points in front of both cameras.
// Observations are normalised image coordinates; residuals are Sampson distances in pixels
// through focal_px. Convention: x2^T E x1 = 0 with E = [t]x R and x2 ~ R x1 + t, so
// (R, t) is cam2_from_cam1; |t| = 1 (scale is unobservable).
#pragma once

#include <cmath>
#include <optional>
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

// RANSAC over the motion (R, t) instead of E: each five-point solution is decomposed and kept
// with every decomposition that puts the sample in front of both cameras, and a correspondence
// whose point lies behind either camera is an outlier. Scored on E alone, a wrong solution of a
// nearly planar scene (aerial nadir views) that explains the flow within the threshold but puts
// half the points behind the cameras can win: measured on a 640x360 lawnmower clip at 100 m,
// every other bootstrap attempt came out with a 0.25 deg median triangulation angle instead of
// 5-13 deg. Points whose rays are closer than min_parallax_rad do not vote (depth sign is noise).
class RelativeMotionEstimator {
 public:
  using Datum = TwoViewCorrespondence;
  struct Model {
    Eigen::Matrix3d R;  // cam2_from_cam1 rotation
    Eigen::Vector3d t;  // cam2_from_cam1 translation, |t| = 1
    Eigen::Matrix3d E;  // [t]x R, kept for Residual (evaluated for every datum)
  };
  static constexpr int kMinSampleSize = 5;

  RelativeMotionEstimator(double focal_px, double min_parallax_rad)
      : essential_(focal_px), min_parallax_rad_(min_parallax_rad) {}

  std::vector<Model> Fit(std::span<const Datum> sample) const;
  // Sampson distance in pixels; infinite for a point behind either camera.
  double Residual(const Model& m, const Datum& d) const;
  bool Refine(std::span<const Datum> inliers, Model* m) const;

 private:
  bool Behind(const Model& m, const Datum& d) const;

  EssentialEstimator essential_;
  double min_parallax_rad_;
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

// Motions whose camera-2 centre directions (seen from camera 1) differ by more than this are
// in different basins (the two motions of a nearly planar scene differ by tens of degrees).
inline constexpr double kDistinctMotionDeg = 10.0;

// Whether two motions, given as unit camera-2 centre directions, lie in different basins.
inline bool DistinctMotions(const Eigen::Vector3d& centre_direction_a, const Eigen::Vector3d& centre_direction_b) {
  return centre_direction_a.dot(centre_direction_b) < std::cos(kDistinctMotionDeg * M_PI / 180.0);
}

// Steers EstimateRelativePose between near-equivalent motions: among the candidates whose MSAC
// cost is at most max_cost_ratio times the lowest, the one whose camera-2 centre direction
// (unit, camera 1 frame) is closest to `centre_direction` is chosen.
struct MotionPreference {
  Eigen::Vector3d centre_direction = Eigen::Vector3d::UnitZ();
  double max_cost_ratio = 1.0;
};

// RANSAC (RelativeMotionEstimator), then the homography's decompositions refined on the
// inliers as alternative motions (the lowest MSAC cost wins: nearly planar scenes have a second,
// wrong motion whose basin five-point samples often fall into; essential.cc), then
// RecoverRelativePose. options.inlier_threshold in pixels.
// success requires options.min_inliers (and 5) inliers after cheirality.
// max_depth as in RecoverRelativePose: raise it where small baselines are expected (a
// bootstrap watching parallax grow decides on triangulation angles itself).
// `preference` (optional) chooses among near-equivalent motions as described there.
RelativePoseResult EstimateRelativePose(std::span<const TwoViewCorrespondence> data,
                                        double focal_px, const RansacOptions& options,
                                        double max_depth = 50.0,
                                        const std::optional<MotionPreference>& preference = std::nullopt);

}  // namespace glam
