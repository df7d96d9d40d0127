#include "engine/geo/georeference.h"

#include <algorithm>
#include <cmath>

#include <Eigen/SVD>
#include <fmt/format.h>

#include "engine/core/error.h"
#include "engine/core/median.h"
#include "engine/core/options.h"
#include "engine/core/similarity_alignment.h"

namespace glam {
namespace {

// Yaw (about z), scale and offset mapping world[i] onto enu[i]: least squares over the
// horizontal coordinates (a complex-number fit), the vertical offset from the means.
Sim3 FitYawScaleOffset(const std::vector<Eigen::Vector3d>& world, const std::vector<Eigen::Vector3d>& enu) {
  Eigen::Vector3d mean_w = Eigen::Vector3d::Zero(), mean_e = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < world.size(); ++i) {
    mean_w += world[i];
    mean_e += enu[i];
  }
  mean_w /= static_cast<double>(world.size());
  mean_e /= static_cast<double>(enu.size());
  double re = 0, im = 0, norm = 0;
  for (std::size_t i = 0; i < world.size(); ++i) {
    const Eigen::Vector2d a = (world[i] - mean_w).head<2>(), b = (enu[i] - mean_e).head<2>();
    re += a.x() * b.x() + a.y() * b.y();  // conj(a) * b
    im += a.x() * b.y() - a.y() * b.x();
    norm += a.squaredNorm();
  }
  if (!(norm > 0)) throw InputError("the camera centres do not move horizontally");
  const double scale = std::hypot(re, im) / norm;
  const SO3 yaw = SO3::Exp(Eigen::Vector3d(0, 0, std::atan2(im, re)));
  return Sim3(scale, yaw, mean_e - scale * (yaw * mean_w));
}

}  // namespace

void GeoreferenceOptions::Check() const {
  CheckGreaterEqual("GeoreferenceOptions.min_samples", min_samples, 3);
  CheckGreater("GeoreferenceOptions.min_extent_m", min_extent_m, 0.0);
  CheckGreater("GeoreferenceOptions.outlier_factor", outlier_factor, 1.0);
  CheckGreaterEqual("GeoreferenceOptions.min_outlier_m", min_outlier_m, 0.0);
  CheckInRange("GeoreferenceOptions.min_spread_ratio", min_spread_ratio, 0.0, 1.0);
  CheckGreater("GeoreferenceOptions.max_rms_fraction", max_rms_fraction, 0.0);
}

GeoreferenceResult FitGeoreference(const std::map<std::int64_t, Eigen::Vector3d>& centres_by_frame, double fps,
                                   const std::vector<GpsSample>& gps, const GeoreferenceOptions& options) {
  options.Check();
  GeoreferenceResult result;
  if (gps.empty() || !(fps > 0)) {
    result.reason = "no GPS samples";
    return result;
  }
  result.origin = gps.front().position;
  const EnuFrame frame(result.origin);
  std::vector<Eigen::Vector3d> world, enu;
  for (const GpsSample& s : gps) {
    const double at = s.time_s * fps;
    const auto index = static_cast<std::int64_t>(std::llround(at));
    const auto it = centres_by_frame.find(index);
    if (it == centres_by_frame.end() || std::abs(at - static_cast<double>(index)) > 0.5) continue;
    world.push_back(it->second);
    enu.push_back(frame.EnuFromGeodetic(s.position));
  }
  result.samples_matched = static_cast<int>(world.size());
  if (result.samples_matched < options.min_samples) {
    result.reason = fmt::format("{} GPS samples fall on posed frames, {} needed", result.samples_matched,
                                options.min_samples);
    return result;
  }
  // Horizontal spread of the GPS positions: extent and whether a tilt is observable.
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const Eigen::Vector3d& e : enu) mean += e.head<2>();
  mean /= static_cast<double>(enu.size());
  Eigen::MatrixXd centred(enu.size(), 2);
  for (std::size_t i = 0; i < enu.size(); ++i) centred.row(static_cast<Eigen::Index>(i)) = (enu[i].head<2>() - mean).transpose();
  const Eigen::Vector2d spread = Eigen::JacobiSVD<Eigen::MatrixXd>(centred).singularValues() /
                                 std::sqrt(static_cast<double>(enu.size()));
  // The length of a line sampled evenly with that spread (sqrt(12) sigma): GPS noise around a
  // hover does not add up to a flight the way the farthest sample would.
  result.extent_m = std::sqrt(12.0) * spread.x();
  if (result.extent_m < options.min_extent_m) {
    result.reason = fmt::format("the GPS positions span {:.1f} m, {:.0f} m needed", result.extent_m,
                                options.min_extent_m);
    return result;
  }
  // A tilt about the main direction is observable only if the flight also spans the minimum
  // extent across it: GPS noise alone spreads a straight line ~1-2 m sideways, which against a
  // short line passed the ratio (measured: a 13 m line, 1 m noise, ratio 0.26) and let the tilt
  // follow the noise (the ground 120 m off at 100 m altitude).
  result.full = spread.y() >= options.min_spread_ratio * spread.x() &&
                std::sqrt(12.0) * spread.y() >= options.min_extent_m;

  std::vector<bool> used(world.size(), true);
  for (int round = 0; round < 3; ++round) {
    std::vector<Eigen::Vector3d> w, e;
    for (std::size_t i = 0; i < world.size(); ++i) {
      if (!used[i]) continue;
      w.push_back(world[i]);
      e.push_back(enu[i]);
    }
    if (static_cast<int>(w.size()) < options.min_samples) {
      result.reason = "too many GPS samples disagree with the map";
      return result;
    }
    try {
      result.enu_from_world = result.full ? AlignSimilarity(w, e).target_from_source : FitYawScaleOffset(w, e);
    } catch (const InputError& error) {
      result.reason = error.what();
      return result;
    }
    std::vector<double> residuals;
    for (std::size_t i = 0; i < world.size(); ++i) residuals.push_back((result.enu_from_world * world[i] - enu[i]).norm());
    double sum = 0;
    int count = 0;
    for (std::size_t i = 0; i < world.size(); ++i) {
      if (!used[i]) continue;
      sum += residuals[i] * residuals[i];
      ++count;
    }
    result.samples_used = count;
    result.rms_m = std::sqrt(sum / std::max(1, count));
    if (round == 2) {
      if (result.rms_m > options.max_rms_fraction * result.extent_m) {
        result.reason = fmt::format("the GPS positions scatter by {:.1f} m around a {:.0f} m flight",
                                    result.rms_m, result.extent_m);
        return result;
      }
      break;
    }
    std::vector<double> used_residuals;
    for (std::size_t i = 0; i < world.size(); ++i) {
      if (used[i]) used_residuals.push_back(residuals[i]);
    }
    const double gate = std::max(options.min_outlier_m, options.outlier_factor * UpperMedian(used_residuals));
    for (std::size_t i = 0; i < world.size(); ++i) used[i] = residuals[i] <= gate;
  }
  result.ok = true;
  return result;
}

}  // namespace glam
