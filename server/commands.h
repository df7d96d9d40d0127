// Registration of the `glam` subcommands. Each Register* adds one subcommand with its own
// options to the app and a callback that runs it. Callbacks throw glam::InputError for bad
// user input; main() turns that into a message on stderr and exit code 2.
#pragma once

#include <CLI/CLI.hpp>

namespace glam::cli {

void RegisterEvalCommand(CLI::App& app);
void RegisterSynthCommand(CLI::App& app);
void RegisterMapCommand(CLI::App& app);
void RegisterVocabCommand(CLI::App& app);
void RegisterServeCommand(CLI::App& app);
void RegisterUploadCommand(CLI::App& app);

}  // namespace glam::cli
