#include "tools/eval/evaluation.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>

#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/export/ply_points.h"
#include "engine/export/tum_trajectory.h"

namespace glam::eval {
namespace {

constexpr const char* kGtTrajectory = "gt_trajectory.tum";
constexpr const char* kGtSurface = "gt_surface.json";
constexpr const char* kSynthOptions = "synth.json";
constexpr const char* kTrajectory = "trajectory.tum";
constexpr const char* kPoints = "points.ply";

void RequireDirectory(const std::filesystem::path& dir, const char* what) {
  if (!std::filesystem::is_directory(dir)) {
    throw InputError(fmt::format("{} directory {} does not exist", what, dir.string()));
  }
}

std::optional<double> FpsFromSynthJson(const std::filesystem::path& path) {
  if (!std::filesystem::exists(path)) return std::nullopt;
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("cannot open {}", path.string()));
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(fmt::format("{} is not valid JSON: {}", path.string(), e.what()));
  }
  if (!j.is_object() || !j.contains("fps") || !j["fps"].is_number()) {
    throw InputError(fmt::format("{}: missing numeric field 'fps'", path.string()));
  }
  const double fps = j["fps"].get<double>();
  if (!(fps > 0) || !std::isfinite(fps)) {
    throw InputError(fmt::format("{}: 'fps' must be > 0, got {}", path.string(), fps));
  }
  return fps;
}

// Frame rate from the median spacing of ground-truth timestamps (every frame is posed in
// ground truth, so the spacing is one frame period).
double FpsFromTimestamps(const std::vector<TimedPose>& gt, const std::filesystem::path& path) {
  std::vector<double> t;
  for (const TimedPose& p : gt) t.push_back(p.timestamp);
  std::sort(t.begin(), t.end());
  std::vector<double> dt;
  for (std::size_t k = 1; k < t.size(); ++k) {
    if (t[k] > t[k - 1]) dt.push_back(t[k] - t[k - 1]);
  }
  if (dt.empty()) {
    throw InputError(
        fmt::format("cannot infer the frame rate from {} (give --fps)", path.string()));
  }
  std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
  return 1.0 / dt[dt.size() / 2];
}

nlohmann::json Nullable(bool present, double value) {
  return present && std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

nlohmann::json Nullable(const std::optional<double>& value) {
  return value ? Nullable(true, *value) : nlohmann::json(nullptr);
}

std::string HorizonKey(double horizon_s) { return fmt::format("{}s", horizon_s); }

}  // namespace

void EvaluationOptions::Check() const {
  trajectory.Check();
  if (!(fps >= 0) || !std::isfinite(fps))
    throw InputError(fmt::format("fps must be >= 0, got {}", fps));
  if (!(max_surface_search_radius > 0)) {
    throw InputError(
        fmt::format("max surface search radius must be > 0, got {}", max_surface_search_radius));
  }
}

EvaluationResult EvaluateDirectories(const std::filesystem::path& gt_dir,
                                     const std::filesystem::path& result_dir,
                                     const EvaluationOptions& options) {
  options.Check();
  RequireDirectory(gt_dir, "ground-truth");
  RequireDirectory(result_dir, "result");
  EvaluationResult r;
  r.gt_dir = gt_dir;
  r.result_dir = result_dir;

  const std::filesystem::path gt_path = gt_dir / kGtTrajectory;
  const std::vector<TimedPose> gt = ReadTumTrajectory(gt_path);
  if (gt.empty()) throw InputError(fmt::format("{} has no poses", gt_path.string()));
  const std::filesystem::path est_path = result_dir / kTrajectory;
  const std::vector<TimedPose> estimate = ReadTumTrajectory(est_path);
  if (estimate.empty()) {
    throw InputError(fmt::format("{} has no poses (no frame was localised)", est_path.string()));
  }

  r.fps = options.fps;
  if (r.fps == 0) {
    const auto from_synth = FpsFromSynthJson(gt_dir / kSynthOptions);
    r.fps = from_synth ? *from_synth : FpsFromTimestamps(gt, gt_path);
  }
  r.match_tolerance_s = 0.5 / r.fps;
  r.trajectory = EvaluateTrajectory(gt, estimate, r.match_tolerance_s, options.trajectory);

  const std::filesystem::path points_path = result_dir / kPoints;
  if (std::filesystem::exists(points_path)) {
    const std::filesystem::path surface_path = gt_dir / kGtSurface;
    if (!std::filesystem::exists(surface_path)) {
      GLAM_LOG_WARN("{} has no {}: map accuracy is not evaluated", gt_dir.string(), kGtSurface);
    } else {
      const HeightfieldSurface surface = HeightfieldSurface::Load(surface_path);
      const std::vector<ColoredPoint> points = ReadPlyPoints(points_path);
      r.map = EvaluateMap(points, r.trajectory.gt_from_estimate, surface,
                          options.max_surface_search_radius);
    }
  }
  return r;
}

nlohmann::json ToJson(const EvaluationResult& r) {
  const TrajectoryMetrics& t = r.trajectory;
  const Sim3& g = t.gt_from_estimate;
  nlohmann::json rpe = nlohmann::json::object();
  for (const RelativePoseError& e : t.rpe) {
    const bool ok = e.pairs > 0;
    rpe[HorizonKey(e.horizon_s)] = {{"horizon_s", e.horizon_s},
                                    {"pairs", e.pairs},
                                    {"translation_rmse_m", Nullable(ok, e.translation_rmse)},
                                    {"rotation_rmse_deg", Nullable(ok, e.rotation_rmse_deg)}};
  }
  nlohmann::json j = {
      {"gt_dir", r.gt_dir.string()},
      {"result_dir", r.result_dir.string()},
      {"fps", r.fps},
      {"match_tolerance_s", r.match_tolerance_s},
      {"alignment",
       {{"type", t.scale_estimated ? "sim3" : "se3"},
        {"scale", g.scale()},
        {"rotation_deg", g.rotation().Log().norm() * 180.0 / std::numbers::pi},
        {"translation", {g.translation().x(), g.translation().y(), g.translation().z()}}}},
      {"trajectory",
       {{"gt_frames", t.gt_frames},
        {"estimated_poses", t.estimated_poses},
        {"matched_frames", t.matched},
        {"fraction_posed", t.fraction_posed},
        {"ate_rmse_m", t.ate_rmse},
        {"ate_mean_m", t.ate_mean},
        {"ate_median_m", t.ate_median},
        {"ate_max_m", t.ate_max},
        {"orientation_rmse_deg", t.orientation_rmse_deg},
        {"rpe", rpe},
        {"scale_drift_percent", Nullable(t.scale_drift_percent)},
        {"scale_first_third", Nullable(t.scale_first_third)},
        {"scale_last_third", Nullable(t.scale_last_third)}}},
      {"map", nullptr}};
  if (r.map) {
    const MapMetrics& m = *r.map;
    const bool ok = m.evaluated > 0;
    j["map"] = {{"points", m.points},
                {"evaluated_points", m.evaluated},
                {"outside_points", m.outside},
                {"rmse_m", Nullable(ok, m.rmse)},
                {"mean_m", Nullable(ok, m.mean)},
                {"median_m", Nullable(ok, m.median)},
                {"within_0_5m", Nullable(ok, m.within_0_5m)},
                {"within_1m", Nullable(ok, m.within_1m)}};
  }
  return j;
}

std::string Summary(const EvaluationResult& r) {
  const TrajectoryMetrics& t = r.trajectory;
  std::string s = fmt::format("posed {:.1f}% ({}/{}) | ATE {:.3f} m", 100.0 * t.fraction_posed,
                              t.matched, t.gt_frames, t.ate_rmse);
  for (const RelativePoseError& e : t.rpe) {
    if (e.pairs > 0) {
      s += fmt::format(" | RPE {} {:.3f} m {:.2f} deg", HorizonKey(e.horizon_s), e.translation_rmse,
                       e.rotation_rmse_deg);
    } else {
      s += fmt::format(" | RPE {} n/a", HorizonKey(e.horizon_s));
    }
  }
  s += t.scale_drift_percent ? fmt::format(" | scale drift {:.2f}%", *t.scale_drift_percent)
                             : std::string(" | scale drift n/a");
  if (r.map && r.map->evaluated > 0) {
    const MapMetrics& m = *r.map;
    s += fmt::format(
        " | map RMSE {:.3f} m, median {:.3f} m, {:.1f}% < 0.5 m, {:.1f}% < 1 m ({} points)", m.rmse,
        m.median, 100.0 * m.within_0_5m, 100.0 * m.within_1m, m.points);
  } else if (r.map) {
    s += fmt::format(" | map: none of {} points over the ground-truth surface", r.map->points);
  }
  return s;
}

}  // namespace glam::eval
