// The pipeline's TileWriter on synthetic submaps: tiles are written once per completed submap
// and never change afterwards, each revision rewrites tileset.json (both variants) atomically,
// points read back from a written tile and carried by the tileset's transform land at
// world_from_submap * point_in_submap, a resumed writer recovers earlier submaps from disk,
// map.glb holds the connected submaps in world frame, an empty submap is handled, and a
// reader polling tileset.json during rewrites never sees half a file.
#include <atomic>
#include <cmath>
#include <random>
#include <thread>

#include <gtest/gtest.h>

#include "engine/export/tileset.h"
#include "engine/map/submap_io.h"
#include "engine/pipeline/tile_writer.h"
#include "tests/export/glb_test_util.h"

namespace glam {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

Submap MakeSubmap(std::uint32_t id, int landmarks, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Submap s;
  s.id = id;
  s.first_frame = 50 * id;
  s.last_frame = 50 * id + 59;
  for (int i = 0; i < landmarks; ++i) {
    Landmark lm;
    lm.id = static_cast<std::uint32_t>(i);
    lm.point_in_submap = Eigen::Vector3d(30 * u(rng), 20 * u(rng), 0.5 * u(rng) - 10);
    lm.color = {static_cast<std::uint8_t>(i & 0xff), static_cast<std::uint8_t>(i >> 8), static_cast<std::uint8_t>(id)};
    s.landmarks.push_back(lm);
  }
  for (std::int64_t f = s.first_frame; f <= s.last_frame; ++f) {
    FramePose fp;
    fp.frame_index = f;
    // Camera looking down from 10 units above the ground: cam_from_submap = (R, -R c).
    const Eigen::Vector3d centre(0.3 * static_cast<double>(f - s.first_frame), 0, 0);
    const SO3 R(Eigen::Matrix3d(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX())));
    fp.cam_from_submap = SE3(R, -(R.matrix() * centre));
    fp.pnp_inliers = 100;
    s.frame_poses.push_back(fp);
  }
  return s;
}

SubmapPlacement Place(std::uint32_t id, double scale, double yaw, Eigen::Vector3d t, bool disconnected = false) {
  SubmapPlacement p;
  p.id = id;
  p.world_from_submap = Sim3(scale, SO3(Eigen::Matrix3d(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()))), t);
  p.disconnected = disconnected;
  p.first_frame = 50 * id;
  p.last_frame = 50 * id + 59;
  return p;
}

json ReadJson(const fs::path& path) { return json::parse(glam::testing::ReadBytes(path)); }

using glam::testing::FromColumnMajor;

// Reads tile `id` from disk as a 3D Tiles client would (quantized variant: dequantize, y-up ->
// z-up happens in DequantizePoints) and places its points with the tileset's transform; every
// source landmark (matched by its colour) must land at world_from_submap * point_in_submap.
// `open`: the open submap's preview child instead of the submap's own, with URI query `query`.
void ExpectTilePlacedInWorld(const fs::path& dir, const json& tileset, const Submap& submap,
                             const Sim3& world_from_submap, bool open = false,
                             const std::string& query = "?v=run1") {
  const json* child = nullptr;
  for (const json& c : tileset["root"]["children"]) {
    if (c["extras"]["submap"] == submap.id && c["extras"].value("open", false) == open) child = &c;
  }
  ASSERT_NE(child, nullptr);
  const Eigen::Matrix4d transform = FromColumnMajor((*child)["transform"]);
  const std::string uri = (*child)["content"]["uri"];
  ASSERT_EQ(uri.substr(uri.find('?')), query);
  const std::string file = uri.substr(0, uri.find('?'));
  EXPECT_EQ(file.find(".open."), open ? file.find('.') : std::string::npos) << file;
  const tinygltf::Model model = glam::testing::ParseGlb(glam::testing::ReadBytes(dir / file));
  const bool quantized = uri.find(".quantized.") != std::string::npos;
  const std::vector<ColoredPoint> points =
      quantized ? glam::testing::DequantizePoints(model) : glam::testing::DecodeDracoPoints(model);
  ASSERT_EQ(points.size(), submap.landmarks.size());
  for (const ColoredPoint& p : points) {
    const std::size_t index = p.color[0] | (static_cast<std::size_t>(p.color[1]) << 8);
    ASSERT_LT(index, submap.landmarks.size());
    const Eigen::Vector3d want = world_from_submap * submap.landmarks[index].point_in_submap;
    const Eigen::Vector3d got = (transform * p.position.cast<double>().homogeneous()).head<3>();
    // Quantisation (<= 60 / 2^15 per coordinate here) times the scale.
    EXPECT_LE((got - want).norm(), 5e-3 * world_from_submap.scale()) << uri;
  }
}

void ExpectTilePlacedInWorld(const fs::path& dir, const json& tileset, const Submap& submap,
                             const SubmapPlacement& placement) {
  ExpectTilePlacedInWorld(dir, tileset, submap, placement.world_from_submap);
}

TEST(TileWriter, TilesOnceTilesetPerRevisionPointsLandInTheWorld) {
  const fs::path dir = glam::testing::FreshTempDir("tile_writer");
  TileWriter writer(dir, "run1");
  const std::vector<Submap> submaps = {MakeSubmap(0, 800, 1), MakeSubmap(1, 600, 2)};
  writer.OnSubmapCompleted(submaps[0]);
  writer.OnSubmapCompleted(submaps[1]);
  for (const char* name : {"tiles/0.glb", "tiles/0.quantized.glb", "tiles/1.glb", "tiles/1.quantized.glb"}) {
    EXPECT_TRUE(fs::is_regular_file(dir / name)) << name;
  }
  EXPECT_FALSE(fs::exists(dir / "tileset.json"));
  const std::string tile0 = glam::testing::ReadBytes(dir / "tiles/0.glb");
  const auto tile0_time = fs::last_write_time(dir / "tiles/0.glb");

  MapSnapshot rev1;
  rev1.revision = 1;
  rev1.submaps = {Place(0, 1.0, 0.0, Eigen::Vector3d::Zero()), Place(1, 1.7, 0.4, Eigen::Vector3d(20, 5, 1))};
  writer.OnRevision(rev1);
  json tileset = ReadJson(dir / "tileset.json");
  EXPECT_EQ(tileset["asset"]["tilesetVersion"], "1");
  for (std::size_t i = 0; i < 2; ++i) ExpectTilePlacedInWorld(dir, tileset, submaps[i], rev1.submaps[i]);
  const json quantized = ReadJson(dir / "tileset.quantized.json");
  for (std::size_t i = 0; i < 2; ++i) ExpectTilePlacedInWorld(dir, quantized, submaps[i], rev1.submaps[i]);

  // The trajectory in the tile is the submap's camera centres.
  const std::vector<Eigen::Vector3f> trajectory =
      glam::testing::TrajectoryPoints(glam::testing::ParseGlb(glam::testing::ReadBytes(dir / "tiles/1.glb")));
  ASSERT_EQ(trajectory.size(), submaps[1].frame_poses.size());
  EXPECT_LE((trajectory[7] - Eigen::Vector3f(0.3f * 7, 0, 0)).norm(), 1e-5f);

  // An old or repeated revision writes nothing.
  const auto tileset_time = fs::last_write_time(dir / "tileset.json");
  MapSnapshot stale = rev1;
  stale.submaps[1].world_from_submap = Sim3();
  writer.OnRevision(stale);
  EXPECT_EQ(fs::last_write_time(dir / "tileset.json"), tileset_time);
  EXPECT_EQ(ReadJson(dir / "tileset.json"), tileset);

  // A loop closure moves submap 1: new tileset, same tiles, points at the new place.
  MapSnapshot rev2 = rev1;
  rev2.revision = 2;
  rev2.submaps[1] = Place(1, 0.8, -1.2, Eigen::Vector3d(-7, 30, 2));
  writer.OnRevision(rev2);
  tileset = ReadJson(dir / "tileset.json");
  EXPECT_EQ(tileset["extras"]["revision"], 2);
  ExpectTilePlacedInWorld(dir, tileset, submaps[1], rev2.submaps[1]);
  EXPECT_EQ(glam::testing::ReadBytes(dir / "tiles/0.glb"), tile0);
  EXPECT_EQ(fs::last_write_time(dir / "tiles/0.glb"), tile0_time);
  EXPECT_EQ(writer.last_revision_written(), 2);
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    EXPECT_NE(entry.path().extension(), ".tmp") << entry.path();
  }
  fs::remove_all(dir);
}

TEST(TileWriter, ResumedWriterRecoversEarlierSubmapsFromDisk) {
  const fs::path dir = glam::testing::FreshTempDir("tile_writer_resume");
  const std::vector<Submap> submaps = {MakeSubmap(0, 300, 5), MakeSubmap(1, 300, 6), MakeSubmap(2, 300, 7)};
  for (const Submap& s : submaps) WriteSubmap(s, dir / "submaps");
  {
    TileWriter first(dir, "run1");
    first.OnSubmapCompleted(submaps[0]);
  }
  const std::string tile0 = glam::testing::ReadBytes(dir / "tiles/0.glb");
  const auto tile0_time = fs::last_write_time(dir / "tiles/0.glb");
  TileWriter resumed(dir, "run1");  // knows nothing about submaps 0 and 1
  resumed.OnSubmapCompleted(submaps[2]);
  MapSnapshot snapshot;
  snapshot.revision = 5;
  snapshot.submaps = {Place(0, 1, 0, Eigen::Vector3d::Zero()), Place(1, 1.1, 0.2, Eigen::Vector3d(30, 0, 0)),
                      Place(2, 0.9, 0.3, Eigen::Vector3d(60, 0, 0))};
  resumed.OnRevision(snapshot);
  const json tileset = ReadJson(dir / "tileset.json");
  ASSERT_EQ(tileset["root"]["children"].size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) ExpectTilePlacedInWorld(dir, tileset, submaps[i], snapshot.submaps[i]);
  // Tile 0 existed and was kept as it was; tile 1 was missing and has been written.
  EXPECT_EQ(fs::last_write_time(dir / "tiles/0.glb"), tile0_time);
  EXPECT_EQ(glam::testing::ReadBytes(dir / "tiles/0.glb"), tile0);
  EXPECT_TRUE(fs::is_regular_file(dir / "tiles/1.quantized.glb"));
  fs::remove_all(dir);
}

TEST(TileWriter, MapGlbHoldsTheConnectedSubmapsInWorldFrame) {
  const fs::path dir = glam::testing::FreshTempDir("tile_writer_map");
  std::vector<Submap> submaps = {MakeSubmap(0, 400, 8), MakeSubmap(1, 300, 9), MakeSubmap(2, 200, 10)};
  // Submap 0 posed overlap frames 50..54 by rotation only (a hovering yaw), submap 1 by PnP.
  for (FramePose& fp : submaps[0].frame_poses) {
    if (fp.frame_index >= 50 && fp.frame_index <= 54) fp.pnp_inliers = 0;
  }
  for (const Submap& s : submaps) WriteSubmap(s, dir / "submaps");
  MapSnapshot snapshot;
  snapshot.revision = 3;
  snapshot.submaps = {Place(0, 1, 0, Eigen::Vector3d::Zero()), Place(1, 1.3, 0.5, Eigen::Vector3d(25, 3, 0)),
                      Place(2, 1, 0, Eigen::Vector3d(90, 0, 0), /*disconnected=*/true)};
  TileWriter writer(dir, "run1");
  EXPECT_EQ(writer.WriteMapGlb(snapshot, dir / "submaps"), 700);
  const tinygltf::Model model = glam::testing::ParseGlb(glam::testing::ReadBytes(dir / "map.glb"));
  const std::vector<ColoredPoint> points = glam::testing::DecodeDracoPoints(model);
  ASSERT_EQ(points.size(), 700u);
  std::vector<ColoredPoint> world;
  for (std::size_t i = 0; i < 2; ++i) {
    for (const Landmark& lm : submaps[i].landmarks) {
      ColoredPoint p;
      p.position = (snapshot.submaps[i].world_from_submap * lm.point_in_submap).cast<float>();
      p.color = lm.color;
      world.push_back(p);
    }
  }
  const double bound = DracoPositionErrorBound(world, DracoTileOptions{}.position_bits) + 1e-4;
  for (const ColoredPoint& p : points) {
    ASSERT_LT(p.color[2], 2) << "a disconnected submap's point is in map.glb";
    const std::size_t index = p.color[0] | (static_cast<std::size_t>(p.color[1]) << 8);
    const Eigen::Vector3f want = world[p.color[2] == 0 ? index : 400 + index].position;
    EXPECT_LE((p.position - want).cwiseAbs().maxCoeff(), bound);
  }
  // One camera centre per frame; submaps 0 and 1 overlap in frames 50..59, where the centre is
  // the one trajectory.tum has (AddFramePoses): submap 0's where it posed by PnP, submap 1's
  // where submap 0 posed by rotation only.
  const std::vector<Eigen::Vector3f> path = glam::testing::TrajectoryPoints(model);
  ASSERT_EQ(path.size(), 110u);
  const auto centre = [&](std::size_t submap, std::int64_t frame) {
    const FramePose& fp = submaps[submap].frame_poses[static_cast<std::size_t>(frame - submaps[submap].first_frame)];
    return (snapshot.submaps[submap].world_from_submap * fp.cam_from_submap.Inverse().translation()).cast<float>().eval();
  };
  for (const std::int64_t frame : {std::int64_t{20}, std::int64_t{57}, std::int64_t{59}}) {
    EXPECT_LE((path[static_cast<std::size_t>(frame)] - centre(0, frame)).norm(), 1e-3f) << frame;
  }
  for (const std::int64_t frame : {std::int64_t{50}, std::int64_t{54}, std::int64_t{80}}) {
    EXPECT_LE((path[static_cast<std::size_t>(frame)] - centre(1, frame)).norm(), 1e-3f) << frame;
  }
  EXPECT_GT((centre(0, 52) - centre(1, 52)).norm(), 1.0f);  // the two submaps' poses differ there
  fs::remove_all(dir);
}

TEST(TileWriter, EmptySubmapGetsValidTilesButNoTilesetChild) {
  const fs::path dir = glam::testing::FreshTempDir("tile_writer_empty");
  TileWriter writer(dir, "run1");
  writer.OnSubmapCompleted(MakeSubmap(0, 100, 1));
  writer.OnSubmapCompleted(MakeSubmap(1, 0, 2));
  const tinygltf::Model empty = glam::testing::ParseGlb(glam::testing::ReadBytes(dir / "tiles/1.glb"));
  EXPECT_EQ(glam::testing::FindNode(empty, "points"), -1);
  EXPECT_GE(glam::testing::FindNode(empty, "trajectory"), 0);
  const json report = glam::testing::ValidateGltf(dir / "tiles/1.quantized.glb");
  ASSERT_FALSE(report.is_null());
  EXPECT_EQ(report["issues"]["numErrors"], 0) << report.dump(1);
  MapSnapshot snapshot;
  snapshot.revision = 1;
  snapshot.submaps = {Place(0, 1, 0, Eigen::Vector3d::Zero()), Place(1, 1, 0, Eigen::Vector3d(10, 0, 0))};
  writer.OnRevision(snapshot);
  const json tileset = ReadJson(dir / "tileset.json");
  ASSERT_EQ(tileset["root"]["children"].size(), 1u);
  EXPECT_EQ(tileset["root"]["children"][0]["extras"]["submap"], 0);
  fs::remove_all(dir);
}

TEST(TileWriter, ReadersNeverSeeAHalfWrittenTileset) {
  const fs::path dir = glam::testing::FreshTempDir("tile_writer_atomic");
  TileWriter writer(dir, "run1");
  MapSnapshot snapshot;
  for (std::uint32_t id = 0; id < 40; ++id) {
    writer.OnSubmapCompleted(MakeSubmap(id, 20, id));
    snapshot.submaps.push_back(Place(id, 1, 0.1 * id, Eigen::Vector3d(10.0 * id, 0, 0)));
  }
  snapshot.revision = 1;
  writer.OnRevision(snapshot);
  std::atomic<bool> done{false};
  int reads = 0, bad = 0;
  std::int64_t last_seen = 0;
  std::thread reader([&] {
    while (!done) {
      const json t = json::parse(glam::testing::ReadBytes(dir / "tileset.json"), nullptr, false);
      ++reads;
      if (t.is_discarded() || t["root"]["children"].size() != 40) {
        ++bad;
        continue;
      }
      const std::int64_t revision = t["extras"]["revision"];
      if (revision < last_seen) ++bad;  // revisions only grow
      last_seen = revision;
    }
  });
  for (int r = 2; r <= 150; ++r) {
    snapshot.revision = r;
    snapshot.submaps[5].world_from_submap = Sim3(1.0 + 0.01 * r, SO3(), Eigen::Vector3d::Zero());
    writer.OnRevision(snapshot);
  }
  done = true;
  reader.join();
  EXPECT_GT(reads, 0);
  EXPECT_EQ(bad, 0) << "of " << reads << " reads";
  EXPECT_EQ(ReadJson(dir / "tileset.json")["extras"]["revision"], 150);
  fs::remove_all(dir);
}

// The open submap's live preview: listed in both tilesets beside the revision's submaps,
// placed on its anchor's placement of each revision, under a new URI per rewrite; gone once a
// revision places the submap itself (or when cleared), and never listed while its anchor is
// not placed (or disconnected).
TEST(TileWriter, OpenSubmapPreviewRidesOnItsAnchorUntilItsOwnTileIsPlaced) {
  const fs::path dir = glam::testing::FreshTempDir("tile_writer_preview");
  TileWriter writer(dir, "run1");
  const Submap first = MakeSubmap(0, 500, 11);
  Submap open = MakeSubmap(1, 300, 12);
  const Sim3 anchor_from_open(0.8, SO3(Eigen::Matrix3d(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()))),
                              Eigen::Vector3d(10, 0, 0));
  writer.OnSubmapCompleted(first);

  // Submap 0 is not placed yet: nothing to ride on.
  EXPECT_FALSE(writer.OnOpenSubmapPreview(open, 0u, anchor_from_open));
  EXPECT_FALSE(fs::exists(dir / "tiles/1.open.glb"));
  EXPECT_FALSE(fs::exists(dir / "tileset.json"));
  EXPECT_FALSE(writer.open_preview().has_value());

  MapSnapshot rev1;
  rev1.revision = 1;
  rev1.submaps = {Place(0, 1.3, 0.2, Eigen::Vector3d(1, 2, 3))};
  writer.OnRevision(rev1);
  ASSERT_TRUE(writer.OnOpenSubmapPreview(open, 0u, anchor_from_open));
  ASSERT_TRUE(writer.open_preview().has_value());
  EXPECT_EQ(writer.open_preview()->first, 1u);
  EXPECT_EQ(writer.open_preview()->second, open.first_frame);
  json tileset = ReadJson(dir / "tileset.json");
  EXPECT_EQ(tileset["extras"]["revision"], 1) << "a preview is not a map revision";
  ASSERT_EQ(tileset["root"]["children"].size(), 2u);
  const json& extras = tileset["root"]["children"][1]["extras"];
  EXPECT_EQ(extras["open"], true);
  EXPECT_EQ(extras["disconnected"], false);
  EXPECT_EQ(extras["first_frame"], open.first_frame);
  EXPECT_EQ(extras["last_frame"], open.last_frame);
  ExpectTilePlacedInWorld(dir, tileset, first, rev1.submaps[0]);
  ExpectTilePlacedInWorld(dir, tileset, open, rev1.submaps[0].world_from_submap * anchor_from_open, true,
                          "?v=run1-open1");
  ExpectTilePlacedInWorld(dir, ReadJson(dir / "tileset.quantized.json"), open,
                          rev1.submaps[0].world_from_submap * anchor_from_open, true, "?v=run1-open1");

  // The submap grows: the tile is rewritten under a new URI.
  open.landmarks.resize(200);
  ASSERT_TRUE(writer.OnOpenSubmapPreview(open, 0u, anchor_from_open));
  tileset = ReadJson(dir / "tileset.json");
  ExpectTilePlacedInWorld(dir, tileset, open, rev1.submaps[0].world_from_submap * anchor_from_open, true,
                          "?v=run1-open2");

  // Alignment moves submap 0: the preview moves with it.
  MapSnapshot rev2 = rev1;
  rev2.revision = 2;
  rev2.submaps[0] = Place(0, 0.9, -0.5, Eigen::Vector3d(-4, 0, 1));
  writer.OnRevision(rev2);
  tileset = ReadJson(dir / "tileset.json");
  ExpectTilePlacedInWorld(dir, tileset, open, rev2.submaps[0].world_from_submap * anchor_from_open, true,
                          "?v=run1-open2");

  // Its anchor disconnected: no preview in that revision.
  MapSnapshot rev3 = rev2;
  rev3.revision = 3;
  rev3.submaps[0].disconnected = true;
  writer.OnRevision(rev3);
  EXPECT_EQ(ReadJson(dir / "tileset.json")["root"]["children"].size(), 1u);

  // Submap 1 completes and is placed: its own tile replaces the preview, whose files go.
  writer.OnSubmapCompleted(open);
  MapSnapshot rev4 = rev2;
  rev4.revision = 4;
  rev4.submaps.push_back(Place(1, 1.1, 0.1, Eigen::Vector3d(8, 1, 0)));
  writer.OnRevision(rev4);
  tileset = ReadJson(dir / "tileset.json");
  ASSERT_EQ(tileset["root"]["children"].size(), 2u);
  for (const json& child : tileset["root"]["children"]) EXPECT_FALSE(child["extras"].value("open", false));
  ExpectTilePlacedInWorld(dir, tileset, open, rev4.submaps[1]);
  EXPECT_FALSE(fs::exists(dir / "tiles/1.open.glb"));
  EXPECT_FALSE(fs::exists(dir / "tiles/1.open.quantized.glb"));
  EXPECT_FALSE(writer.open_preview().has_value());
  // A late preview of a placed submap is refused.
  EXPECT_FALSE(writer.OnOpenSubmapPreview(open, 0u, anchor_from_open));
  fs::remove_all(dir);
}

// The run's first submap is previewed before any revision, levelled on its own (no anchor);
// ClearOpenPreview (a discarded submap, the end of the run) takes it out again.
TEST(TileWriter, FirstSubmapPreviewWithoutAnchorAndClear) {
  const fs::path dir = glam::testing::FreshTempDir("tile_writer_first_preview");
  TileWriter writer(dir, "run1");
  const Submap open = MakeSubmap(0, 400, 13);
  const Sim3 world_from_open(1.0, SO3(Eigen::Matrix3d(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()))),
                             Eigen::Vector3d(0, 0, 10));
  ASSERT_TRUE(writer.OnOpenSubmapPreview(open, std::nullopt, world_from_open));
  json tileset = ReadJson(dir / "tileset.json");
  EXPECT_EQ(tileset["extras"]["revision"], 0);
  ASSERT_EQ(tileset["root"]["children"].size(), 1u);
  ExpectTilePlacedInWorld(dir, tileset, open, world_from_open, true, "?v=run1-open1");
  writer.ClearOpenPreview();
  tileset = ReadJson(dir / "tileset.json");
  EXPECT_FALSE(tileset["root"].contains("children"));
  EXPECT_FALSE(fs::exists(dir / "tiles/0.open.glb"));
  EXPECT_FALSE(writer.open_preview().has_value());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace glam
