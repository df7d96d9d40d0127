#include "api/ids.h"

#include <set>

#include <gtest/gtest.h>

namespace glam::api {
namespace {

TEST(Ids, NewIdsAreValidAndDistinct) {
  std::set<std::string> seen;
  for (int i = 0; i < 1000; ++i) {
    const std::string id = NewJobId();
    EXPECT_TRUE(IsValidJobId(id)) << id;
    seen.insert(id);
  }
  EXPECT_EQ(seen.size(), 1000u);
}

TEST(Ids, RejectsAnythingThatIsNotSixteenLowerHex) {
  EXPECT_TRUE(IsValidJobId("0123456789abcdef"));
  for (const char* bad : {"", "..", "0123456789abcde", "0123456789abcdef0", "0123456789ABCDEF",
                          "0123456789abcde/", "../../etc/passw", "0123456789abcd.f",
                          "%2e%2e%2f0123456"}) {
    EXPECT_FALSE(IsValidJobId(bad)) << bad;
  }
}

TEST(Ids, ParsesOnlyPlainNonNegativeIntegers) {
  long long v = -1;
  EXPECT_TRUE(ParseNonNegativeInt("0", &v));
  EXPECT_EQ(v, 0);
  EXPECT_TRUE(ParseNonNegativeInt("1234", &v));
  EXPECT_EQ(v, 1234);
  for (const char* bad : {"", "-1", "+1", "1.0", " 1", "1e3", "..", "0x10", "1234567890123456789"}) {
    EXPECT_FALSE(ParseNonNegativeInt(bad, &v)) << bad;
  }
}

}  // namespace
}  // namespace glam::api
