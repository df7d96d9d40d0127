// Triangulation of landmarks from posed views. Observations are NORMALISED image coordinates
// (the point on the z = 1 plane, i.e. Camera::Unproject(pixel).head<2>() with distortion
// already removed), so one code path serves every camera model; `focal_px` converts errors
// back to pixels where thresholds are given in pixels. Poses are cam_from_world.
//
// Linear DLT first (Hartley & Zisserman 12.2), then optional Gauss-Newton on the reprojection
// error, then the checks a new landmark must pass: enough parallax (a point seen along nearly
// parallel rays has an unbounded depth error), in front of every camera, small reprojection
// error in every view.
#pragma once

#include <optional>
#include <span>

#include <Eigen/Core>

#include "engine/core/se3.h"

namespace glam {

// World position of the camera centre of a cam_from_world pose.
Eigen::Vector3d CameraCenter(const SE3& cam_from_world);

// Angle (radians) between the rays from two camera centres to a point.
double TriangulationAngle(const Eigen::Vector3d& center1, const Eigen::Vector3d& center2,
                          const Eigen::Vector3d& point);

// Linear (DLT) triangulation from >= 2 views. nullopt if the solution is at infinity
// (parallel rays) or fewer than 2 views are given.
std::optional<Eigen::Vector3d> TriangulateDlt(std::span<const SE3> cams_from_world,
                                              std::span<const Eigen::Vector2d> normalized);

// Gauss-Newton on the sum of squared normalised reprojection errors. Returns false (point
// unchanged) if the point is behind a camera or the normal equations are singular.
bool RefineTriangulation(std::span<const SE3> cams_from_world,
                         std::span<const Eigen::Vector2d> normalized, Eigen::Vector3d* point,
                         int max_iterations = 10);

// Normalised reprojection error of a world point in one view (+inf if behind the camera).
double NormalizedReprojectionError(const SE3& cam_from_world, const Eigen::Vector3d& point,
                                   const Eigen::Vector2d& normalized);

struct TriangulationOptions {
  // The largest angle between any two viewing rays must reach this.
  double min_angle_deg = 1.0;
  // Maximum reprojection error in every view, in pixels (normalised error * focal_px).
  double max_error_px = 4.0;
  double focal_px = 1000.0;
  bool refine = true;

  void Check() const;  // throws InputError
};

enum class TriangulationStatus {
  kOk,
  kTooFewViews,
  kDegenerate,     // DLT solution at infinity
  kSmallAngle,     // not enough parallax
  kBehindCamera,   // negative depth in some view
  kLargeError,     // reprojection error above max_error_px in some view
};

struct Triangulation {
  TriangulationStatus status = TriangulationStatus::kTooFewViews;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double max_angle_rad = 0.0;   // largest pairwise ray angle
  double max_error_px = 0.0;    // largest reprojection error over the views
  bool ok() const { return status == TriangulationStatus::kOk; }
};

Triangulation Triangulate(std::span<const SE3> cams_from_world,
                          std::span<const Eigen::Vector2d> normalized,
                          const TriangulationOptions& options = {});

}  // namespace glam
