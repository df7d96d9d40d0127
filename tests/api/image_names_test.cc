// The clean-name rule for photos (api/image_names.h) against the cases in
// image_names_cases.json, which the viewer's copy of the rule (web/src/image_names.js) is
// checked against too (tests/web/image_names_test.mjs): the two must name a photo alike.
#include "api/image_names.h"

#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace glam::api {
namespace {

TEST(ImageNames, CleanNamesMatchTheCasesTheViewerIsCheckedAgainst) {
  std::ifstream in(std::string(GLAM_SOURCE_DIR) + "/tests/api/image_names_cases.json");
  ASSERT_TRUE(in);
  const nlohmann::json cases = nlohmann::json::parse(in);
  ASSERT_GE(cases.size(), 10u);
  for (const nlohmann::json& c : cases) {
    const std::string name = c.at("name");
    const std::string clean = c.at("clean");
    const bool image = c.at("image");
    SCOPED_TRACE(c.at("why").get<std::string>());
    EXPECT_EQ(SafeImageName(name), image ? clean : std::string()) << name;
    // A set takes exactly the clean names, and names the clean form of any other.
    const std::string why = UncleanImageNameMessage(name);
    if (image && clean == name) {
      EXPECT_EQ(why, "") << name;
    } else {
      EXPECT_NE(why, "") << name;
      if (image) {
        EXPECT_NE(why.find("send it as \"" + clean + "\""), std::string::npos) << why;
      }
      EXPECT_EQ(UncleanImageNameMessage(clean), image ? "" : NotAnImageNameMessage(clean)) << clean;
    }
  }
}

}  // namespace
}  // namespace glam::api
