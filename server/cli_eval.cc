// `glam eval --gt DIR --result DIR [--json FILE] [--format text|json] [--no-scale] [--fps F]`
// Prints a one-line summary (or the JSON report with --format json) on stdout; --json also
// writes the report to a file, for benchmarks and CI.
#include <fmt/format.h>

#include <fstream>
#include <iostream>
#include <memory>
#include <string>

#include "engine/core/error.h"
#include "server/commands.h"
#include "tools/eval/evaluation.h"

namespace glam::cli {
namespace {

struct EvalArgs {
  std::string gt_dir;
  std::string result_dir;
  std::string json_path;
  std::string format = "text";
  bool no_scale = false;
  eval::EvaluationOptions options;
};

void RunEval(const EvalArgs& args) {
  eval::EvaluationOptions options = args.options;
  options.trajectory.estimate_scale = !args.no_scale;
  const eval::EvaluationResult result =
      eval::EvaluateDirectories(args.gt_dir, args.result_dir, options);
  const nlohmann::json report = eval::ToJson(result);
  if (!args.json_path.empty()) {
    std::ofstream out(args.json_path);
    out << report.dump(2) << "\n";
    out.close();
    if (!out) throw EnvironmentError(fmt::format("cannot write {}", args.json_path));
  }
  if (args.format == "json") {
    std::cout << report.dump(2) << std::endl;
  } else {
    std::cout << eval::Summary(result) << std::endl;
  }
}

}  // namespace

void RegisterEvalCommand(CLI::App& app) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* cmd = app.add_subcommand(
      "eval", "Evaluate a trajectory (and point cloud) against synthetic ground truth");
  cmd->add_option("--gt", args->gt_dir, "Ground-truth directory written by `glam synth`")
      ->required();
  cmd->add_option("--result", args->result_dir,
                  "Result directory with trajectory.tum and optionally points.ply")
      ->required();
  cmd->add_option("--json", args->json_path, "Also write the JSON report to this file");
  cmd->add_option("--format", args->format, "Output on stdout: text (one line) or json")
      ->check(CLI::IsMember({"text", "json"}))
      ->capture_default_str();
  cmd->add_flag("--no-scale", args->no_scale, "Align with SE3 (scale fixed to 1) instead of Sim3");
  cmd->add_option("--fps", args->options.fps,
                  "Frame rate of the timestamps (default: synth.json, else inferred)");
  cmd->add_option("--rpe-horizons", args->options.trajectory.rpe_horizons_s,
                  "Relative pose error horizons in seconds")
      ->capture_default_str();
  cmd->callback([args] { RunEval(*args); });
}

}  // namespace glam::cli
