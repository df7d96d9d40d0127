// Exact synthetic geometry for estimator tests: known poses, points, observations.
#pragma once

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "engine/core/se3.h"

namespace glam::testing {

inline double Deg(double rad) { return rad * 180.0 / std::numbers::pi; }
inline double Rad(double deg) { return deg * std::numbers::pi / 180.0; }

// Angle of the rotation a^-1 b (degrees).
inline double RotationErrorDeg(const SO3& a, const SO3& b) {
  return Deg((a.Inverse() * b).Log().norm());
}

inline double AngleBetweenDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return Deg(std::atan2(a.cross(b).norm(), a.dot(b)));
}

// A camera looking roughly down (+z of the camera towards -z of the world) from `height`.
inline SE3 DownwardCamera(const Eigen::Vector3d& center, double yaw_deg, double tilt_deg) {
  const SO3 world_from_cam = SO3::Exp(Eigen::Vector3d(0, 0, Rad(yaw_deg))) *
                             SO3::Exp(Eigen::Vector3d(Rad(tilt_deg), 0, 0)) *
                             SO3::Exp(Eigen::Vector3d(std::numbers::pi, 0, 0));
  const SO3 cam_from_world = world_from_cam.Inverse();
  return SE3(cam_from_world, -(cam_from_world * center));
}

// Normalised observation of a world point (assumes it is in front).
inline Eigen::Vector2d Observe(const SE3& cam_from_world, const Eigen::Vector3d& point) {
  const Eigen::Vector3d p = cam_from_world * point;
  return p.head<2>() / p.z();
}

// World points visible in a camera: random normalised coordinates within +-half_fov_tan and
// depths in [near, far].
inline std::vector<Eigen::Vector3d> PointsInView(const SE3& cam_from_world, int n, double near,
                                                 double far, double half_fov_tan,
                                                 std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-half_fov_tan, half_fov_tan), depth(near, far);
  const SE3 world_from_cam = cam_from_world.Inverse();
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i) {
    const double z = depth(rng);
    points.push_back(world_from_cam * Eigen::Vector3d(u(rng) * z, u(rng) * z * 0.6, z));
  }
  return points;
}

}  // namespace glam::testing
