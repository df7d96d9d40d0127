#include "engine/geometry/triangulation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include <Eigen/Cholesky>
#include <Eigen/SVD>

#include "engine/core/camera.h"
#include "engine/core/error.h"
#include "engine/core/options.h"

namespace glam {

Eigen::Vector3d CameraCenter(const SE3& cam_from_world) {
  return -(cam_from_world.rotation().Inverse() * cam_from_world.translation());
}

double TriangulationAngle(const Eigen::Vector3d& center1, const Eigen::Vector3d& center2,
                          const Eigen::Vector3d& point) {
  const Eigen::Vector3d a = point - center1, b = point - center2;
  // atan2 of |a x b| and a.b is accurate for tiny and near-pi angles alike.
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

std::optional<Eigen::Vector3d> TriangulateDlt(std::span<const SE3> cams_from_world,
                                              std::span<const Eigen::Vector2d> normalized) {
  GLAM_CHECK(cams_from_world.size() == normalized.size());
  const size_t n = cams_from_world.size();
  if (n < 2) return std::nullopt;
  Eigen::MatrixXd A(2 * n, 4);
  for (size_t i = 0; i < n; ++i) {
    Eigen::Matrix<double, 3, 4> P;
    P.leftCols<3>() = cams_from_world[i].rotation().matrix();
    P.col(3) = cams_from_world[i].translation();
    const Eigen::Vector2d& x = normalized[i];
    A.row(static_cast<Eigen::Index>(2 * i)) = x.x() * P.row(2) - P.row(0);
    A.row(static_cast<Eigen::Index>(2 * i + 1)) = x.y() * P.row(2) - P.row(1);
  }
  // Equilibrate rows so every view weighs the same.
  for (Eigen::Index r = 0; r < A.rows(); ++r) {
    const double norm = A.row(r).norm();
    if (norm > 0) A.row(r) /= norm;
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d X = svd.matrixV().col(3);
  if (std::abs(X(3)) < 1e-12 * X.head<3>().norm() || X(3) == 0.0) return std::nullopt;
  const Eigen::Vector3d point = X.head<3>() / X(3);
  if (!point.allFinite()) return std::nullopt;
  return point;
}

double NormalizedReprojectionError(const SE3& cam_from_world, const Eigen::Vector3d& point,
                                   const Eigen::Vector2d& normalized) {
  const Eigen::Vector3d p = cam_from_world * point;
  if (p.z() <= Camera::kMinDepth) return std::numeric_limits<double>::infinity();
  return (p.head<2>() / p.z() - normalized).norm();
}

bool RefineTriangulation(std::span<const SE3> cams_from_world,
                         std::span<const Eigen::Vector2d> normalized, Eigen::Vector3d* point,
                         int max_iterations) {
  GLAM_CHECK(cams_from_world.size() == normalized.size());
  Eigen::Vector3d X = *point;
  for (int it = 0; it < max_iterations; ++it) {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < cams_from_world.size(); ++i) {
      const Eigen::Matrix3d R = cams_from_world[i].rotation().matrix();
      const Eigen::Vector3d p = R * X + cams_from_world[i].translation();
      if (p.z() <= Camera::kMinDepth) return false;
      const double iz = 1.0 / p.z();
      const Eigen::Vector2d r = p.head<2>() * iz - normalized[i];
      Eigen::Matrix<double, 2, 3> dproj;
      dproj << iz, 0, -p.x() * iz * iz, 0, iz, -p.y() * iz * iz;
      const Eigen::Matrix<double, 2, 3> J = dproj * R;
      H += J.transpose() * J;
      g += J.transpose() * r;
    }
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(H);
    if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-14)) return false;
    const Eigen::Vector3d step = -ldlt.solve(g);
    if (!step.allFinite()) return false;
    X += step;
    if (step.norm() <= 1e-12 * (1.0 + X.norm())) break;
  }
  for (size_t i = 0; i < cams_from_world.size(); ++i) {
    if ((cams_from_world[i] * X).z() <= Camera::kMinDepth) return false;
  }
  *point = X;
  return true;
}

void TriangulationOptions::Check() const {
  CheckInRange("TriangulationOptions.min_angle_deg", min_angle_deg, 0.0, 90.0);
  CheckGreater("TriangulationOptions.max_error_px", max_error_px, 0.0);
  CheckGreater("TriangulationOptions.focal_px", focal_px, 0.0);
}

Triangulation Triangulate(std::span<const SE3> cams_from_world,
                          std::span<const Eigen::Vector2d> normalized,
                          const TriangulationOptions& options) {
  GLAM_CHECK(cams_from_world.size() == normalized.size());
  Triangulation result;
  if (cams_from_world.size() < 2) return result;
  const auto dlt = TriangulateDlt(cams_from_world, normalized);
  if (!dlt) {
    result.status = TriangulationStatus::kDegenerate;
    return result;
  }
  result.point = *dlt;
  if (options.refine) RefineTriangulation(cams_from_world, normalized, &result.point);

  std::vector<Eigen::Vector3d> centers;
  centers.reserve(cams_from_world.size());
  for (const SE3& pose : cams_from_world) centers.push_back(CameraCenter(pose));
  for (size_t i = 0; i < centers.size(); ++i) {
    for (size_t j = i + 1; j < centers.size(); ++j) {
      result.max_angle_rad =
          std::max(result.max_angle_rad, TriangulationAngle(centers[i], centers[j], result.point));
    }
  }
  bool behind = false;
  for (size_t i = 0; i < cams_from_world.size(); ++i) {
    const double e = NormalizedReprojectionError(cams_from_world[i], result.point, normalized[i]);
    behind = behind || std::isinf(e);
    result.max_error_px = std::max(result.max_error_px, e * options.focal_px);
  }
  if (behind) {
    result.status = TriangulationStatus::kBehindCamera;
  } else if (result.max_angle_rad < options.min_angle_deg * std::numbers::pi / 180.0) {
    result.status = TriangulationStatus::kSmallAngle;
  } else if (result.max_error_px > options.max_error_px) {
    result.status = TriangulationStatus::kLargeError;
  } else {
    result.status = TriangulationStatus::kOk;
  }
  return result;
}

}  // namespace glam
