#include "engine/submap/centre_smoothing.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>

#include "engine/core/camera.h"
#include "engine/core/median.h"
#include "engine/core/options.h"
#include "engine/core/so3.h"

namespace glam {
namespace {

// Weighted least-squares quadratic c(t) = a + b (t - t0) + c (t - t0)^2 (rows a, b, c; one
// column per axis) over frames [begin, end).
bool FitQuadratic(const std::vector<double>& times, const std::vector<Eigen::Vector3d>& centres,
                  const std::vector<double>& weights, std::size_t begin, std::size_t end, double t0,
                  Eigen::Matrix3d* coefficients) {
  Eigen::Matrix3d normal = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d rhs = Eigen::Matrix3d::Zero();
  int used = 0;
  for (std::size_t i = begin; i < end; ++i) {
    if (weights[i - begin] <= 0) continue;
    const double dt = times[i] - t0;
    const Eigen::Vector3d basis(1.0, dt, dt * dt);
    normal.noalias() += weights[i - begin] * basis * basis.transpose();
    rhs.noalias() += weights[i - begin] * basis * centres[i].transpose();
    ++used;
  }
  if (used < 4) return false;
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(normal);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) return false;
  *coefficients = ldlt.solve(rhs);
  return coefficients->allFinite();
}

Eigen::Vector3d Evaluate(const Eigen::Matrix3d& coefficients, double dt) {
  return (coefficients.row(0) + dt * coefficients.row(1) + dt * dt * coefficients.row(2)).transpose();
}

// The centre at frame `at` from a robust fit over [begin, end): iteratively reweighted, each
// round leaving out the frames beyond outlier_sigmas robust deviations of the window's fit
// (the scale from the median residual; a 3-D residual's norm has median ~1.54 sigma).
bool RobustCentre(const std::vector<double>& times, const std::vector<Eigen::Vector3d>& centres,
                  std::size_t begin, std::size_t end, std::size_t at, double outlier_sigmas,
                  Eigen::Vector3d* centre) {
  std::vector<double> weights(end - begin, 1.0);
  Eigen::Matrix3d coefficients;
  if (!FitQuadratic(times, centres, weights, begin, end, times[at], &coefficients)) return false;
  for (int round = 0; round < 3; ++round) {
    std::vector<double> residuals(end - begin);
    for (std::size_t i = begin; i < end; ++i) {
      residuals[i - begin] = (centres[i] - Evaluate(coefficients, times[i] - times[at])).norm();
    }
    const double sigma = UpperMedian(residuals) / 1.54;
    std::vector<double> next(end - begin);
    for (std::size_t k = 0; k < residuals.size(); ++k) {
      next[k] = residuals[k] <= outlier_sigmas * sigma ? 1.0 : 0.0;
    }
    if (next == weights) break;
    Eigen::Matrix3d refit;
    if (!FitQuadratic(times, centres, next, begin, end, times[at], &refit)) break;
    weights = std::move(next);
    coefficients = refit;
  }
  *centre = coefficients.row(0).transpose();
  return true;
}

}  // namespace

void CentreSmoothingOptions::Check() const {
  CheckInRange("CentreSmoothingOptions.half_window_s", half_window_s, 0.0, 5.0);
  CheckGreaterEqual("CentreSmoothingOptions.min_frames", min_frames, 5);
  CheckGreater("CentreSmoothingOptions.outlier_sigmas", outlier_sigmas, 0.0);
  CheckGreater("CentreSmoothingOptions.jump_factor", jump_factor, 1.0);
}

std::vector<Eigen::Vector3d> SmoothCentres(const std::vector<double>& times_s,
                                           const std::vector<Eigen::Vector3d>& centres,
                                           const CentreSmoothingOptions& options) {
  const std::size_t n = centres.size();
  std::vector<Eigen::Vector3d> out = centres;
  if (options.half_window_s <= 0 || n < 2) return out;
  // Pieces between jumps: a step far beyond the typical steps on either side of it is no
  // flight (a frozen stream catching up, dropped frames), and a window across it would blur
  // it. Typical = the median step over half a window before and after (the larger): a drone
  // that hovers, then flies off, speeds up smoothly and is no jump, whatever the video's
  // overall median step.
  std::vector<double> steps(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) steps[i] = (centres[i + 1] - centres[i]).norm();
  auto typical_step = [&](std::size_t step) {
    const double t = times_s[step];
    std::vector<double> before, after;
    for (std::size_t k = step; k-- > 0 && times_s[k] >= t - options.half_window_s;) before.push_back(steps[k]);
    for (std::size_t k = step + 1; k + 1 < n && times_s[k + 1] <= times_s[step + 1] + options.half_window_s; ++k) {
      after.push_back(steps[k]);
    }
    return std::max(before.empty() ? 0.0 : UpperMedian(before), after.empty() ? 0.0 : UpperMedian(after));
  };
  std::vector<double> jump(n - 1);
  for (std::size_t i = 0; i + 1 < n; ++i) jump[i] = options.jump_factor * typical_step(i);
  // A single frame off the path and back (one wrong pose) is no jump: the robust fit replaces it.
  std::vector<bool> splits(n, false);  // splits[i]: a piece ends before frame i
  for (std::size_t i = 1; i < n; ++i) splits[i] = steps[i - 1] > jump[i - 1];
  for (std::size_t k = 1; k + 1 < n; ++k) {
    if (splits[k] && splits[k + 1] &&
        (centres[k + 1] - centres[k - 1]).norm() <= 2.0 * std::max(jump[k - 1], jump[k])) {
      splits[k] = splits[k + 1] = false;
    }
  }
  std::size_t piece_begin = 0;
  for (std::size_t piece_end = 1; piece_end <= n; ++piece_end) {
    if (piece_end < n && !splits[piece_end]) continue;
    for (std::size_t i = piece_begin, begin = piece_begin, end = piece_begin; i < piece_end; ++i) {
      while (times_s[begin] < times_s[i] - options.half_window_s) ++begin;
      while (end < piece_end && times_s[end] <= times_s[i] + options.half_window_s) ++end;
      if (end - begin < static_cast<std::size_t>(options.min_frames)) continue;
      Eigen::Vector3d centre;
      if (RobustCentre(times_s, centres, begin, end, i, options.outlier_sigmas, &centre)) out[i] = centre;
    }
    piece_begin = piece_end;
  }
  return out;
}

bool SolveRotationWithCentre(const std::vector<Eigen::Vector2d>& normalized,
                             const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& centre,
                             SE3* cam_from_world) {
  if (normalized.size() != points.size() || points.size() < 4) return false;
  SO3 rotation = cam_from_world->rotation();
  for (int iteration = 0; iteration < 10; ++iteration) {
    // p = R (X - c); left update R <- Exp(w) R: dp/dw = -[p]x.
    Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    int used = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3d p = rotation * (points[i] - centre);
      if (p.z() <= Camera::kMinDepth) continue;
      const double iz = 1.0 / p.z();
      const Eigen::Vector2d r = p.head<2>() * iz - normalized[i];
      Eigen::Matrix<double, 2, 3> dproj;
      dproj << iz, 0, -p.x() * iz * iz, 0, iz, -p.y() * iz * iz;
      const Eigen::Matrix<double, 2, 3> j = -dproj * Hat(p);
      h.noalias() += j.transpose() * j;
      g.noalias() += j.transpose() * r;
      ++used;
    }
    if (used < 4) return false;
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(h);
    if (ldlt.info() != Eigen::Success) return false;
    const Eigen::Vector3d step = -ldlt.solve(g);
    if (!step.allFinite()) return false;
    rotation = SO3::Exp(step) * rotation;
    if (step.norm() < 1e-12) break;
  }
  *cam_from_world = SE3(rotation, -(rotation * centre));
  return true;
}

}  // namespace glam
