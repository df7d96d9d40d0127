// The main() of every GLAM test executable: gtest's, plus GLAM_LOG_LEVEL=debug (or any level
// `glam --log-level` takes) to see the engine's log while a test runs, e.g.
//   GLAM_LOG_LEVEL=debug build/tests/alignment/glam_global_alignment_test --gtest_filter='*Loop*'
#include <cstdlib>

#include <gtest/gtest.h>

#include "engine/core/logging.h"

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  if (const char* level = std::getenv("GLAM_LOG_LEVEL")) glam::InitLogging(level);
  return RUN_ALL_TESTS();
}
