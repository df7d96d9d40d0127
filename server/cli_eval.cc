// `glam eval --gt DIR --result DIR [--json FILE] [--format text|json] [--no-scale] [--fps F]`
// Prints a one-line summary (or the JSON report with --format json) on stdout; --json also
// writes the report to a file, for benchmarks and CI. The disconnected parts of a `glam map`
// result (DIR/parts/<n>/, each in its own frame) are evaluated too, each aligned on its own:
// one more line per part ("parts/<n>: ..."), and "parts" in the JSON report.
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

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

// parts/<n> folders of a result directory, in part order.
std::vector<int> PartNumbers(const std::filesystem::path& result_dir) {
  std::vector<int> numbers;
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(result_dir / "parts", error)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_directory() && !name.empty() && name.size() < 9 &&
        std::all_of(name.begin(), name.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      numbers.push_back(std::stoi(name));
    }
  }
  std::sort(numbers.begin(), numbers.end());
  return numbers;
}

void RunEval(const EvalArgs& args) {
  eval::EvaluationOptions options = args.options;
  options.trajectory.estimate_scale = !args.no_scale;
  const eval::EvaluationResult result =
      eval::EvaluateDirectories(args.gt_dir, args.result_dir, options);
  nlohmann::json report = eval::ToJson(result);
  std::vector<std::string> part_lines;
  nlohmann::json parts = nlohmann::json::array();
  for (const int number : PartNumbers(args.result_dir)) {
    const std::string directory = fmt::format("parts/{}", number);
    nlohmann::json entry = {{"directory", directory}};
    try {
      const eval::EvaluationResult part =
          eval::EvaluateDirectories(args.gt_dir, std::filesystem::path(args.result_dir) / directory, options);
      entry.update(eval::ToJson(part));
      part_lines.push_back(directory + ": " + eval::Summary(part));
    } catch (const InputError& e) {  // e.g. a part of fewer than three frames
      entry["error"] = e.what();
      part_lines.push_back(directory + ": not evaluated: " + e.what());
    }
    parts.push_back(std::move(entry));
  }
  report["parts"] = parts;
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
    for (const std::string& line : part_lines) std::cout << line << std::endl;
  }
}

}  // namespace

void RegisterEvalCommand(CLI::App& app) {
  auto args = std::make_shared<EvalArgs>();
  CLI::App* cmd = app.add_subcommand(
      "eval", "Evaluate a trajectory (and point cloud) against synthetic ground truth; the "
              "disconnected parts of a glam map result (parts/<n>/) each on its own");
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
