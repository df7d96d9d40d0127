#include <gtest/gtest.h>

#include "engine/core/cancellation.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "engine/core/options.h"

namespace glam {
namespace {

TEST(OptionChecks, AcceptValidValues) {
  EXPECT_NO_THROW(CheckGreater("x", 1, 0));
  EXPECT_NO_THROW(CheckGreaterEqual("x", 0.0, 0.0));
  EXPECT_NO_THROW(CheckInRange("x", 0.5, 0.0, 1.0));
}

TEST(OptionChecks, RejectWithNamedMessage) {
  try {
    CheckInRange("SubmapOptions.overlap", 1.5, 0.0, 1.0);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("SubmapOptions.overlap"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("1.5"), std::string::npos);
  }
  EXPECT_THROW(CheckGreater("n", 0, 0), InputError);
  EXPECT_THROW(CheckGreaterEqual("n", -1, 0), InputError);
  // NaN never passes a range check.
  EXPECT_THROW(CheckInRange("f", std::nan(""), 0.0, 1.0), InputError);
}

TEST(CancellationToken, CopiesShareState) {
  CancellationToken token;
  CancellationToken copy = token;
  EXPECT_FALSE(copy.IsCancelled());
  EXPECT_NO_THROW(copy.ThrowIfCancelled());
  token.Cancel();
  EXPECT_TRUE(copy.IsCancelled());
  EXPECT_THROW(copy.ThrowIfCancelled(), Cancelled);
}

TEST(Logging, RejectsUnknownLevel) {
  EXPECT_THROW(InitLogging("loud"), InputError);
}

TEST(CheckMacro, AbortsWithMessage) {
  EXPECT_DEATH(GLAM_CHECK(1 + 1 == 3, "arithmetic {}", "broke"), "arithmetic broke");
}

}  // namespace
}  // namespace glam
