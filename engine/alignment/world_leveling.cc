#include "engine/alignment/world_leveling.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "engine/core/logging.h"
#include "engine/core/median.h"
#include "engine/core/options.h"

namespace glam {

void LevelingOptions::Check() const {
  CheckInRange("LevelingOptions.inlier_fraction", inlier_fraction, 1e-5, 1.0);
  CheckGreater("LevelingOptions.iterations", iterations, 0);
}

namespace {

// Rotation taking `normal` (unit, submap frame) to +z, with the yaw fixed by the submap's x
// axis: it ends up along world +x once projected on the ground. The shortest rotation alone
// (Quaterniond::FromTwoVectors) leaves the yaw to chance when the normal is nearly opposite to
// +z, as under a nadir first camera (the submap frame is its camera frame, z looking down):
// then a plane fitted to a few more landmarks gave a world turned by 30 degrees about the
// vertical (measured: the live preview of a loop's first submap against the completed one).
// The first camera's x axis (image right) is level on gimballed drone cameras, so its
// projection is a stable heading; its y axis stands in when x is nearly vertical.
SO3 LevelRotation(const Eigen::Vector3d& normal) {
  const Eigen::Quaterniond tilt = Eigen::Quaterniond::FromTwoVectors(normal, Eigen::Vector3d::UnitZ());
  Eigen::Vector3d heading = tilt * Eigen::Vector3d::UnitX();
  double yaw_offset = 0;  // where the heading axis should point: world +x (0) or +y (pi / 2)
  if (heading.head<2>().norm() < 0.2) {
    heading = tilt * Eigen::Vector3d::UnitY();
    yaw_offset = M_PI / 2;
  }
  const double yaw = std::atan2(heading.y(), heading.x()) - yaw_offset;
  return SO3(Eigen::Matrix3d((Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitZ()) * tilt).toRotationMatrix()));
}

struct Plane {
  Eigen::Vector3d normal;  // unit
  double offset = 0;       // normal . x + offset = 0
  double Distance(const Eigen::Vector3d& x) const { return std::abs(normal.dot(x) + offset); }
};

Plane LeastSquaresPlane(const std::vector<Eigen::Vector3d>& points, const std::vector<int>& rows) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int r : rows) mean += points[static_cast<std::size_t>(r)];
  mean /= static_cast<double>(rows.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int r : rows) {
    const Eigen::Vector3d d = points[static_cast<std::size_t>(r)] - mean;
    cov += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(cov);
  Plane p;
  p.normal = solver.eigenvectors().col(0).normalized();  // smallest eigenvalue
  p.offset = -p.normal.dot(mean);
  return p;
}

}  // namespace

LevelingResult LevelGround(const std::vector<Eigen::Vector3d>& points,
                           const std::vector<Eigen::Vector3d>& camera_centres,
                           const LevelingOptions& options) {
  LevelingResult result;
  if (points.size() < 3 || camera_centres.empty()) {
    GLAM_LOG_WARN("cannot level the world frame: {} points, {} cameras", points.size(),
                  camera_centres.size());
    return result;
  }
  Eigen::Vector3d cam_mean = Eigen::Vector3d::Zero();
  for (const auto& c : camera_centres) cam_mean += c;
  cam_mean /= static_cast<double>(camera_centres.size());
  std::vector<double> ranges;
  ranges.reserve(points.size());
  for (const auto& p : points) ranges.push_back((p - cam_mean).norm());
  const double threshold = options.inlier_fraction * std::max(UpperMedian(std::move(ranges)), 1e-12);

  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<int> pick(0, static_cast<int>(points.size()) - 1);
  std::vector<int> best;
  for (int it = 0; it < options.iterations; ++it) {
    const auto& a = points[static_cast<std::size_t>(pick(rng))];
    const auto& b = points[static_cast<std::size_t>(pick(rng))];
    const auto& c = points[static_cast<std::size_t>(pick(rng))];
    const Eigen::Vector3d n = (b - a).cross(c - a);
    if (n.norm() < 1e-12) continue;
    Plane plane{n.normalized(), 0};
    plane.offset = -plane.normal.dot(a);
    std::vector<int> inliers;
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (plane.Distance(points[i]) <= threshold) inliers.push_back(static_cast<int>(i));
    }
    if (inliers.size() > best.size()) best = std::move(inliers);
  }
  if (best.size() < 3) return result;
  Plane plane = LeastSquaresPlane(points, best);
  if (plane.normal.dot(cam_mean) + plane.offset < 0) {  // cameras must be on the +normal side
    plane.normal = -plane.normal;
    plane.offset = -plane.offset;
  }
  const SO3 rotation = LevelRotation(plane.normal);
  // In the rotated frame the plane is z = -offset; put it at z = 0 and the first camera at x = y = 0.
  const Eigen::Vector3d first = rotation * camera_centres.front();
  const Eigen::Vector3d translation(-first.x(), -first.y(), plane.offset);
  result.world_from_submap = Sim3(1.0, rotation, translation);
  result.levelled = true;
  result.plane_inliers = static_cast<int>(best.size());
  return result;
}

LevelingResult LevelSubmap(const Submap& submap, const LevelingOptions& options) {
  std::vector<Eigen::Vector3d> points, centres;
  points.reserve(submap.landmarks.size());
  for (const Landmark& lm : submap.landmarks) points.push_back(lm.point_in_submap);
  for (const Keyframe& kf : submap.keyframes) centres.push_back(kf.cam_from_submap.Inverse().translation());
  return LevelGround(points, centres, options);
}

Sim3 LevelPart(const Submap& first, const Sim3& part_from_first, const LevelingOptions& options) {
  return LevelSubmap(first, options).world_from_submap * part_from_first.Inverse();
}

}  // namespace glam
