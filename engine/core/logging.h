// Logging with levels through spdlog. One process-wide logger; the CLI sets the level from
// --log-level / GLAM_LOG_LEVEL. Library code never prints to stdout: stdout belongs to the
// commands' machine-readable output (JSON lines, progress bars go to stderr).
#pragma once

#include <string>

#include <spdlog/spdlog.h>

namespace glam {

// Sets up the default logger on stderr. `level` is one of trace, debug, info, warn, error,
// critical, off. Throws InputError for an unknown level.
void InitLogging(const std::string& level);

}  // namespace glam

#define GLAM_LOG_TRACE(...) SPDLOG_TRACE(__VA_ARGS__)
#define GLAM_LOG_DEBUG(...) SPDLOG_DEBUG(__VA_ARGS__)
#define GLAM_LOG_INFO(...) SPDLOG_INFO(__VA_ARGS__)
#define GLAM_LOG_WARN(...) SPDLOG_WARN(__VA_ARGS__)
#define GLAM_LOG_ERROR(...) SPDLOG_ERROR(__VA_ARGS__)
#define GLAM_LOG_CRITICAL(...) SPDLOG_CRITICAL(__VA_ARGS__)
