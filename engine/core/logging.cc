#include "engine/core/logging.h"

#include <spdlog/sinks/stdout_color_sinks.h>

#include "engine/core/error.h"

namespace glam {

void InitLogging(const std::string& level) {
  const spdlog::level::level_enum parsed = spdlog::level::from_str(level);
  if (parsed == spdlog::level::off && level != "off") {
    throw InputError(fmt::format(
        "unknown log level '{}' (use trace, debug, info, warn, error, critical or off)", level));
  }
  spdlog::drop("glam");  // allow re-initialisation (tests, embedded use)
  auto logger = spdlog::stderr_color_mt("glam");
  logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ [%t] %v");
  logger->set_level(parsed);
  spdlog::set_default_logger(logger);
  spdlog::set_level(parsed);
}

}  // namespace glam
