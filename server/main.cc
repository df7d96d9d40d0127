// `glam`: the single executable of GLAM server. Subcommands:
//   synth   render a synthetic aerial video with ground truth
//   eval    evaluate a trajectory / point cloud against ground truth
//   map     build submaps, trajectory and point cloud from a video or image folder
//   vocab   train the vocabulary tree used to find overlapping submaps
//   serve   the mapping server (REST API, job queue, web viewer)
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>

#include <CLI/CLI.hpp>

#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "server/commands.h"

namespace {

constexpr int kExitInputError = 2;
constexpr int kExitEnvironmentError = 3;

std::string DefaultLogLevel() {
  const char* env = std::getenv("GLAM_LOG_LEVEL");
  return env != nullptr ? env : "info";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"GLAM server: Global-Local Airborne Mapping from drone video"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "glam 0.1.0");
  std::string log_level = DefaultLogLevel();
  app.add_option("--log-level", log_level,
                 "trace, debug, info, warn, error, critical or off (env GLAM_LOG_LEVEL)")
      ->capture_default_str();
  app.parse_complete_callback([&] { glam::InitLogging(log_level); });
  // Subcommands pass options they do not know (--log-level) up to here, so the level may
  // follow the command too: `glam map VIDEO --out DIR --log-level debug`.
  app.fallthrough();
  glam::cli::RegisterEvalCommand(app);
  glam::cli::RegisterSynthCommand(app);
  glam::cli::RegisterMapCommand(app);
  glam::cli::RegisterVocabCommand(app);
  glam::cli::RegisterServeCommand(app);
  glam::cli::RegisterUploadCommand(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; a usage error is bad input like any other (exit 2), not one
    // of CLI11's own codes (105, 108, ...).
    return app.exit(e) == 0 ? EXIT_SUCCESS : kExitInputError;
  } catch (const glam::InputError& e) {
    std::cerr << "glam: error: " << e.what() << "\n";
    return kExitInputError;
  } catch (const glam::Cancelled&) {
    std::cerr << "glam: cancelled\n";
    return kExitEnvironmentError;
  } catch (const std::exception& e) {
    std::cerr << "glam: failed: " << e.what() << "\n";
    return kExitEnvironmentError;
  }
  return EXIT_SUCCESS;
}
