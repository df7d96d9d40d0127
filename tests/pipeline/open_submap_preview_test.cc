// The live preview of the open submap in a whole run (engine/pipeline/open_submap_preview.h)
// on the loop fixture (450 frames, six submaps): the map shows up in the tilesets long before
// the first submap completes, every submap is previewed while it is built, and the previews
// are where the ground is. Ground truth: the fixture's surface, in the frame the final
// trajectory's alignment to the true one gives (what `glam eval` scores maps with).
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/core/intrinsics_io.h"
#include "engine/pipeline/mapping_job.h"
#include "engine/pipeline/mapping_options.h"
#include "tests/export/glb_test_util.h"
#include "tests/support/temp_dir.h"
#include "tools/eval/evaluation.h"
#include "tools/eval/map_metrics.h"

namespace glam {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const fs::path kClip = fs::path(GLAM_TEST_FIXTURES_DIR) / "loop";

// One preview as a client saw it: the tileset's open child and its tile's points in the world.
struct SeenPreview {
  std::int64_t submap = -1;
  std::int64_t keyframes = 0;
  std::int64_t submaps_completed = 0;  // when it was written
  std::string uri;
  std::vector<ColoredPoint> world_points;
};

const json* OpenChild(const json& tileset) {
  if (!tileset.at("root").contains("children")) return nullptr;
  for (const json& child : tileset.at("root").at("children")) {
    if (child.at("extras").value("open", false)) return &child;
  }
  return nullptr;
}

SeenPreview ReadPreview(const fs::path& out, const MappingProgress& progress) {
  const json tileset = json::parse(std::ifstream(out / "tileset.json"));
  const json* child = OpenChild(tileset);
  EXPECT_NE(child, nullptr) << "a preview was reported but the tileset lists none";
  SeenPreview seen;
  if (child == nullptr) return seen;
  seen.submap = child->at("extras").at("submap");
  seen.keyframes = child->at("extras").at("keyframes");
  seen.submaps_completed = progress.submaps_completed;
  seen.uri = child->at("content").at("uri");
  seen.world_points = testing::ChildTileWorldPoints(out, *child);
  return seen;
}

TEST(OpenSubmapPreview, ALoopIsShownWhileEachSubmapIsBuiltAndWhereTheGroundIs) {
  const fs::path out = testing::FreshTempDir("open_submap_preview");
  MappingOptions options;
  UseCalibration(&options, ReadIntrinsicsJson(kClip / "intrinsics.json"));
  options.preview.interval_s = 0.1;  // several previews per submap on a fast machine too
  std::vector<SeenPreview> seen;
  std::int64_t previews = 0;
  const MappingReport report = RunMapping(kClip / "video.mp4", out, options, [&](const MappingProgress& p) {
    if (p.previews == previews) return;
    previews = p.previews;
    seen.push_back(ReadPreview(out, p));
    EXPECT_EQ(seen.back().submap, p.preview_submap);
    EXPECT_EQ(seen.back().keyframes, p.preview_keyframes);
  });
  ASSERT_GE(report.submaps, 4);
  ASSERT_FALSE(seen.empty());

  // The map is visible before the first submap completes, and every submap but the last,
  // short one was previewed while it was open, growing from one preview to the next.
  EXPECT_EQ(seen.front().submap, 0);
  EXPECT_EQ(seen.front().submaps_completed, 0);
  std::map<std::int64_t, std::vector<const SeenPreview*>> by_submap;
  for (const SeenPreview& s : seen) by_submap[s.submap].push_back(&s);
  for (std::int64_t id = 0; id + 1 < report.submaps; ++id) {
    ASSERT_EQ(by_submap.count(id), 1u) << "submap " << id << " was never previewed";
    const auto& list = by_submap[id];
    for (const SeenPreview* s : list) EXPECT_LE(s->submaps_completed, id) << "previewed after it completed";
    EXPECT_GE(list.size(), 2u) << "submap " << id;
    EXPECT_GT(list.back()->keyframes, list.front()->keyframes) << "submap " << id;
  }
  std::set<std::string> uris;
  for (const SeenPreview& s : seen) uris.insert(s.uri);
  EXPECT_EQ(uris.size(), seen.size()) << "each rewrite of the open tile needs a new URI (clients cache tiles)";

  // The previews are where the ground is, within a few times the final map's error: the first
  // submap levelled on its own, the later ones placed from the frames they share with the one
  // before (no alignment yet).
  const eval::EvaluationResult result = eval::EvaluateDirectories(kClip, out, {});
  ASSERT_TRUE(result.map.has_value());
  const auto surface = eval::HeightfieldSurface::Load(kClip / "gt_surface.json");
  std::cout << "final map: median " << result.map->median << " m\n";
  for (const auto& [id, list] : by_submap) {
    const SeenPreview& last = *list.back();
    const eval::MapMetrics preview = eval::EvaluateMap(last.world_points, result.trajectory.gt_from_estimate, surface);
    std::cout << "submap " << id << ": " << list.size() << " previews, the last with " << last.keyframes
              << " keyframes, " << preview.points << " points, median " << preview.median << " m, "
              << 100 * preview.within_0_5m << " % within 0.5 m\n";
    EXPECT_GT(preview.evaluated, preview.points / 2) << "submap " << id;
    // The loop flies at 40 m; measured 0.06-0.22 m (the final map: 0.03 m).
    EXPECT_LT(preview.median, 0.4) << "submap " << id;
  }

  // Once the run is over, every submap has its own tile and no preview is left.
  const json final_tileset = json::parse(std::ifstream(out / "tileset.json"));
  EXPECT_EQ(OpenChild(final_tileset), nullptr);
  for (const auto& entry : fs::directory_iterator(out / "tiles")) {
    EXPECT_EQ(entry.path().filename().string().find(".open."), std::string::npos) << entry.path();
  }
}

}  // namespace
}  // namespace glam
