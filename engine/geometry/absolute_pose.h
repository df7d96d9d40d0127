// Camera pose from 2D-3D correspondences (tracking against landmarks, relocalisation): EPnP
// (Lepetit et al. 2009, as in the paper) on minimal samples inside glam::Ransac, then
// Gauss-Newton on all inliers. Observations are normalised image coordinates
// (Camera::Unproject), residuals are reported in pixels through focal_px.
#pragma once

#include <span>
#include <vector>

#include <Eigen/Core>

#include "engine/core/camera.h"
#include "engine/core/se3.h"
#include "engine/geometry/ransac.h"

namespace glam {

struct PnPCorrespondence {
  Eigen::Vector2d normalized;  // observation on the z = 1 plane
  Eigen::Vector3d point;       // landmark in world (submap) coordinates
};

class AbsolutePoseEstimator {
 public:
  using Datum = PnPCorrespondence;
  using Model = SE3;  // cam_from_world
  // OpenCV's EPnP accepts 4 points, but 5 are markedly more stable under noise (and what
  // cv::solvePnPRansac uses); the extra sample point costs little at tracking inlier ratios.
  static constexpr int kMinSampleSize = 5;

  explicit AbsolutePoseEstimator(double focal_px) : focal_px_(focal_px) {}

  std::vector<SE3> Fit(std::span<const Datum> sample) const;
  // Reprojection error in pixels; +inf when the point is behind the camera.
  double Residual(const SE3& cam_from_world, const Datum& datum) const;
  // Gauss-Newton on the inliers' reprojection errors, starting at *model.
  bool Refine(std::span<const Datum> inliers, SE3* cam_from_world) const;

 private:
  double focal_px_;
};

// Convenience for the tracker: pixels (undistorted through `camera`) and world points.
// options.inlier_threshold is in pixels.
RansacResult<SE3> EstimateAbsolutePose(const std::vector<Eigen::Vector2d>& pixels,
                                       const std::vector<Eigen::Vector3d>& points,
                                       const Camera& camera, const RansacOptions& options);

}  // namespace glam
