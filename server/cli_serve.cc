// Placeholder: the owner of this command replaces this file.
#include "server/commands.h"

namespace glam::cli {

void RegisterServeCommand(CLI::App& /*app*/) {}

}  // namespace glam::cli
