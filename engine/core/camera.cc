#include "engine/core/camera.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "engine/core/error.h"
#include "engine/core/options.h"

namespace glam {
namespace {

void CheckFinite(std::string_view name, double value) {
  if (!std::isfinite(value)) throw InputError(fmt::format("{} must be finite, got {}", name, value));
}

}  // namespace

void Intrinsics::SetK1(double value) {
  k1 = value;
  if (k1 != 0) model = "radial";
}

Intrinsics Intrinsics::WithFocal(double focal) const {
  Intrinsics out = *this;
  out.fy = focal * fy / fx;
  out.fx = focal;
  return out;
}

void Intrinsics::Check() const {
  if (model != "pinhole" && model != "radial") {
    throw InputError(
        fmt::format("intrinsics.model must be \"pinhole\" or \"radial\", got \"{}\"", model));
  }
  CheckGreater("intrinsics.width", width, 0);
  CheckGreater("intrinsics.height", height, 0);
  CheckFinite("intrinsics.fx", fx);
  CheckFinite("intrinsics.fy", fy);
  CheckFinite("intrinsics.cx", cx);
  CheckFinite("intrinsics.cy", cy);
  CheckFinite("intrinsics.k1", k1);
  CheckFinite("intrinsics.k2", k2);
  CheckGreater("intrinsics.fx", fx, 0.0);
  CheckGreater("intrinsics.fy", fy, 0.0);
  if (model == "pinhole" && (k1 != 0 || k2 != 0)) {
    throw InputError(fmt::format(
        "intrinsics.model \"pinhole\" has no distortion but k1 = {}, k2 = {}; use \"radial\"",
        k1, k2));
  }
}

Camera::Camera(const Intrinsics& intrinsics) : intrinsics_(intrinsics) { intrinsics_.Check(); }

bool Camera::Project(const Eigen::Vector3d& point_in_cam, Eigen::Vector2d* pixel) const {
  const double z = point_in_cam.z();
  if (!(z > kMinDepth)) return false;
  const double x = point_in_cam.x() / z;
  const double y = point_in_cam.y() / z;
  const double r2 = x * x + y * y;
  const double d = 1.0 + r2 * (intrinsics_.k1 + intrinsics_.k2 * r2);
  *pixel = Eigen::Vector2d(intrinsics_.fx * d * x + intrinsics_.cx,
                           intrinsics_.fy * d * y + intrinsics_.cy);
  return true;
}

Eigen::Matrix<double, 2, 3> Camera::ProjectJacobian(const Eigen::Vector3d& point_in_cam) const {
  const double z = point_in_cam.z();
  GLAM_CHECK(z > kMinDepth, "ProjectJacobian of a point behind the camera (z = {})", z);
  const double inv_z = 1.0 / z;
  const double x = point_in_cam.x() * inv_z;
  const double y = point_in_cam.y() * inv_z;
  const double r2 = x * x + y * y;
  const double d = 1.0 + r2 * (intrinsics_.k1 + intrinsics_.k2 * r2);
  const double dd_dr2 = intrinsics_.k1 + 2.0 * intrinsics_.k2 * r2;
  // d(distorted normalised point) / d(x, y).
  Eigen::Matrix2d d_dist;
  d_dist << d + 2.0 * x * x * dd_dr2, 2.0 * x * y * dd_dr2,  //
      2.0 * x * y * dd_dr2, d + 2.0 * y * y * dd_dr2;
  // d(x, y) / d(point).
  Eigen::Matrix<double, 2, 3> d_norm;
  d_norm << inv_z, 0, -x * inv_z,  //
      0, inv_z, -y * inv_z;
  const Eigen::Matrix2d focal = Eigen::Vector2d(intrinsics_.fx, intrinsics_.fy).asDiagonal();
  return focal * d_dist * d_norm;
}

Eigen::Vector3d Camera::Unproject(const Eigen::Vector2d& pixel) const {
  const double xd = (pixel.x() - intrinsics_.cx) / intrinsics_.fx;
  const double yd = (pixel.y() - intrinsics_.cy) / intrinsics_.fy;
  const double k1 = intrinsics_.k1;
  const double k2 = intrinsics_.k2;
  const double rd = std::hypot(xd, yd);
  if ((k1 == 0 && k2 == 0) || rd == 0) return Eigen::Vector3d(xd, yd, 1.0);
  // Radial distortion keeps the direction, so only the radius needs inverting:
  // solve r (1 + k1 r^2 + k2 r^4) = rd by Newton's method from r = rd.
  double r = rd;
  for (int i = 0; i < 50; ++i) {
    const double r2 = r * r;
    const double f = r * (1.0 + r2 * (k1 + k2 * r2)) - rd;
    const double df = 1.0 + r2 * (3.0 * k1 + 5.0 * k2 * r2);
    if (!(df > 0)) break;  // left the invertible region; keep the last estimate
    const double step = f / df;
    r -= step;
    if (std::abs(step) <= 1e-15 * std::max(r, 1e-300)) break;
  }
  const double ratio = r / rd;
  return Eigen::Vector3d(xd * ratio, yd * ratio, 1.0);
}

bool Camera::InImage(const Eigen::Vector2d& pixel, double margin) const {
  return pixel.x() >= -0.5 + margin && pixel.x() < intrinsics_.width - 0.5 - margin &&
         pixel.y() >= -0.5 + margin && pixel.y() < intrinsics_.height - 0.5 - margin;
}

Eigen::Matrix3d Camera::K() const {
  Eigen::Matrix3d k;
  k << intrinsics_.fx, 0, intrinsics_.cx,  //
      0, intrinsics_.fy, intrinsics_.cy,   //
      0, 0, 1;
  return k;
}

}  // namespace glam
