// `glam eval`: compares a result directory (trajectory.tum, optional points.ply) with a
// ground-truth directory written by `glam synth` (gt_trajectory.tum, synth.json with "fps",
// gt_surface.json + heights). One function does the whole evaluation so that the CLI, the
// benchmarks and the end-to-end tests report the same numbers in the same JSON.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "tools/eval/map_metrics.h"
#include "tools/eval/trajectory_metrics.h"

namespace glam::eval {

struct EvaluationOptions {
  TrajectoryEvalOptions trajectory;
  // Frame rate that turns frame indices into timestamps; 0 = read "fps" from synth.json,
  // or infer it from the ground-truth timestamps if there is no synth.json.
  double fps = 0;
  double max_surface_search_radius = 50.0;  // metres, see HeightfieldSurface::Distance

  void Check() const;
};

struct EvaluationResult {
  std::filesystem::path gt_dir;
  std::filesystem::path result_dir;
  double fps = 0;
  double match_tolerance_s = 0;  // half a frame period
  TrajectoryMetrics trajectory;
  // Present when the result has points.ply and the ground truth has gt_surface.json.
  std::optional<MapMetrics> map;
};

// Throws InputError (with the file name) for missing or malformed inputs, an empty estimated
// trajectory, no overlap in time with the ground truth, or fewer than 3 matched poses.
EvaluationResult EvaluateDirectories(const std::filesystem::path& gt_dir,
                                     const std::filesystem::path& result_dir,
                                     const EvaluationOptions& options);

// Machine-readable report (units in the key names; absent metrics are null).
nlohmann::json ToJson(const EvaluationResult& result);

// One line for humans, e.g.
// "posed 98.0% (196/200) | ATE 0.042 m | RPE 1s 0.010 m 0.05 deg | ... | map RMSE 0.21 m".
std::string Summary(const EvaluationResult& result);

}  // namespace glam::eval
