#include "engine/geometry/rotation_only.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Dense>

#include "engine/core/options.h"

namespace glam {

void RotationOnlyOptions::Check() const {
  CheckGreater("RotationOnlyOptions.inlier_threshold_px", inlier_threshold_px, 0.0);
  CheckGreaterEqual("RotationOnlyOptions.fit_gate_px", fit_gate_px, inlier_threshold_px);
  CheckInRange("RotationOnlyOptions.iterations", iterations, 0, 100);
  CheckInRange("RotationOnlyOptions.min_focal_scale", min_focal_scale, 0.1, 1.0);
  CheckInRange("RotationOnlyOptions.max_focal_scale", max_focal_scale, 1.0, 10.0);
}

namespace {

// Pixel residual of x2 against the rotation model (true focal = scale x focal_px); a huge
// residual when the rotated ray points away from the second camera.
Eigen::Vector2d Residual(const SO3& R, double scale, const TwoViewCorrespondence& d, double focal_px) {
  const Eigen::Vector3d v = R * Eigen::Vector3d(d.x1.x() / scale, d.x1.y() / scale, 1.0);
  if (v.z() <= 1e-9) return Eigen::Vector2d::Constant(1e6);
  return focal_px * (scale * v.head<2>() / v.z() - d.x2);
}

SO3 KabschStart(std::span<const TwoViewCorrespondence> data) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  for (const TwoViewCorrespondence& d : data) {
    m += Eigen::Vector3d(d.x2.x(), d.x2.y(), 1).normalized() *
         Eigen::Vector3d(d.x1.x(), d.x1.y(), 1).normalized().transpose();
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d fix = Eigen::Matrix3d::Identity();
  fix(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1 : 1;
  return SO3(Eigen::Matrix3d(svd.matrixU() * fix * svd.matrixV().transpose()));
}

}  // namespace

RotationOnlyFit FitRotationOnly(std::span<const TwoViewCorrespondence> data, double focal_px,
                                const RotationOnlyOptions& options) {
  options.Check();
  CheckGreater("FitRotationOnly focal_px", focal_px, 0.0);
  RotationOnlyFit fit;
  if (data.size() < 3) return fit;
  SO3 R = KabschStart(data);
  double scale = 1.0;
  const double gate = options.fit_gate_px;
  // Truncated quadratic: outliers cost the same however far they are, so they cannot pull.
  auto cost = [&](const SO3& r, double s) {
    double c = 0;
    for (const TwoViewCorrespondence& d : data) c += std::min(Residual(r, s, d, focal_px).squaredNorm(), gate * gate);
    return c;
  };
  double current = cost(R, scale);
  double damping = 1e-3;
  constexpr double kStep = 1e-6;
  for (int it = 0; it < options.iterations; ++it) {
    // Normal equations over (rotation increment on the left, log focal scale).
    Eigen::Matrix4d jtj = Eigen::Matrix4d::Zero();
    Eigen::Vector4d jtr = Eigen::Vector4d::Zero();
    int used = 0;
    for (const TwoViewCorrespondence& d : data) {
      const Eigen::Vector2d r = Residual(R, scale, d, focal_px);
      if (r.norm() > gate) continue;
      Eigen::Matrix<double, 2, 4> j;
      for (int k = 0; k < 4; ++k) {
        Eigen::Vector4d delta = Eigen::Vector4d::Zero();
        delta[k] = kStep;
        const SO3 Rp = SO3::Exp(delta.head<3>()) * R;
        j.col(k) = (Residual(Rp, scale * std::exp(delta[3]), d, focal_px) - r) / kStep;
      }
      jtj += j.transpose() * j;
      jtr += j.transpose() * r;
      ++used;
    }
    if (used < 3) break;
    // Levenberg-Marquardt: a step is taken only if it lowers the cost, with the focal scale
    // kept in its range (beyond it, a long enough lens makes any sideways move a rotation).
    bool improved = false;
    for (int attempt = 0; attempt < 6 && !improved; ++attempt) {
      Eigen::Matrix4d a = jtj;
      a.diagonal() += damping * jtj.diagonal().cwiseMax(1e-12);
      const Eigen::Vector4d step = a.ldlt().solve(-jtr);
      if (!step.allFinite()) break;
      const SO3 R_new = SO3::Exp(step.head<3>()) * R;
      const double scale_new =
          std::clamp(scale * std::exp(step[3]), options.min_focal_scale, options.max_focal_scale);
      const double c = cost(R_new, scale_new);
      if (c < current) {
        R = R_new;
        scale = scale_new;
        current = c;
        damping = std::max(1e-6, damping / 10);
        improved = true;
      } else {
        damping *= 10;
      }
    }
    if (!improved) break;
  }
  fit.success = true;
  fit.cam2_from_cam1 = R;
  fit.focal_scale = scale;
  for (const TwoViewCorrespondence& d : data) {
    if (Residual(R, scale, d, focal_px).norm() < options.inlier_threshold_px) ++fit.inliers;
  }
  fit.inlier_fraction = static_cast<double>(fit.inliers) / static_cast<double>(data.size());
  return fit;
}

}  // namespace glam
