#include "engine/core/error.h"

#include <cstdio>
#include <cstdlib>

#include "engine/core/logging.h"

namespace glam {

void FailCheck(const char* file, int line, const char* expr, const std::string& msg) {
  // Written to stderr directly as well: the logger may not be set up (or may be the
  // library's stdout default) when an invariant breaks.
  std::fprintf(stderr, "glam: check failed at %s:%d: %s %s\n", file, line, expr, msg.c_str());
  GLAM_LOG_CRITICAL("check failed at {}:{}: {} {}", file, line, expr, msg);
  spdlog::default_logger()->flush();
  std::abort();
}

}  // namespace glam
