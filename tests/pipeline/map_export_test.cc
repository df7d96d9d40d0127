// World poses written to trajectory.tum: world_from_cam composed from world_from_submap (Sim3)
// and cam_from_submap (SE3), with scale acting on the position only; overlap frames come from
// the earlier submap; disconnected submaps stay out of the whole-map files and each
// disconnected part is written on its own, in its own frame, numbered by first frame.
#include "engine/pipeline/map_export.h"

#include <gtest/gtest.h>

#include "engine/export/ply_points.h"
#include "engine/export/tum_trajectory.h"
#include "engine/map/submap_io.h"
#include "engine/pipeline/mapping_report.h"
#include "tests/pipeline/posed_submap.h"

namespace glam {
namespace {

Submap FrameOnlySubmap(std::uint32_t id, std::int64_t first, std::int64_t last, double x) {
  return glam::testing::PosedSubmap(id, first, last, [x](std::int64_t) { return Eigen::Vector3d(x, 0, 0); });
}

SubmapPlacement Placed(std::uint32_t id, const Sim3& world_from_submap, std::int64_t first, std::int64_t last,
                       int part = 0, const Sim3& part_from_submap = Sim3()) {
  SubmapPlacement p;
  p.id = id;
  p.world_from_submap = world_from_submap;
  p.disconnected = part != 0;
  p.first_frame = first;
  p.last_frame = last;
  p.part = part;
  p.part_from_submap = part == 0 ? world_from_submap : part_from_submap;
  return p;
}

TEST(MapExport, OverlapFramesComeFromTheEarlierSubmapAndDisconnectedPartsAreWrittenApart) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "glam_map_export_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "submaps");
  std::filesystem::create_directories(dir / "parts" / "7");  // left by an earlier run
  Submap s0 = FrameOnlySubmap(0, 0, 9, 1.0);
  Submap s1 = FrameOnlySubmap(1, 8, 15, 2.0);
  Submap s2 = FrameOnlySubmap(2, 20, 24, 5.0);
  Submap s3 = FrameOnlySubmap(3, 40, 44, 1.0);  // a part of its own, before s4's
  Submap s4 = FrameOnlySubmap(4, 30, 34, 1.0);
  Landmark lm;
  lm.point_in_submap = {1, 2, 3};
  lm.color = {10, 20, 30};
  s1.landmarks.push_back(lm);
  s2.landmarks.push_back(lm);
  for (const Submap* s : {&s0, &s1, &s2, &s3, &s4}) WriteSubmap(*s, dir / "submaps");
  MapSnapshot snapshot;
  snapshot.revision = 3;
  const Sim3 world_from_s1(2.0, SO3(), Eigen::Vector3d(0, 0, 1));
  // Part 9 (submaps 2 and 3, frames 20-44) and part 8 (submap 4, frames 30-34): numbered by
  // first frame, so 9 is written as parts/1 and 8 as parts/2. Too few landmarks to level a
  // part, so each part's frame is its first submap's (LevelSubmap returns the identity).
  const Sim3 part9_from_s2(1.0, SO3(), Eigen::Vector3d(0, 0, 0));
  const Sim3 part9_from_s3(3.0, SO3(), Eigen::Vector3d(0, 10, 0));
  snapshot.submaps = {Placed(0, Sim3(), 0, 9), Placed(1, world_from_s1, 8, 15),
                      Placed(2, Sim3(), 20, 24, 9, part9_from_s2), Placed(3, Sim3(), 40, 44, 9, part9_from_s3),
                      Placed(4, Sim3(), 30, 34, 8, Sim3())};
  const MapExportCounts counts = ExportWorldMap(snapshot, dir / "submaps", dir, 10.0);
  EXPECT_EQ(counts.frames_posed, 16);
  EXPECT_EQ(counts.points, 1);
  EXPECT_EQ(counts.submaps_exported, 2);
  const std::vector<TimedPose> poses = ReadTumTrajectory(dir / "trajectory.tum");
  ASSERT_EQ(poses.size(), 16u);
  EXPECT_NEAR(poses[8].timestamp, 0.8, 1e-12);
  EXPECT_NEAR(poses[8].world_from_cam.translation().x(), 1.0, 1e-9);   // from submap 0
  EXPECT_NEAR(poses[10].world_from_cam.translation().x(), 4.0, 1e-9);  // 2 x 2.0 from submap 1
  const std::vector<ColoredPoint> points = ReadPlyPoints(dir / "points.ply");
  ASSERT_EQ(points.size(), 1u);
  EXPECT_NEAR(points[0].position.z(), 7.0f, 1e-5);  // 2 x 3 + 1
  EXPECT_EQ(points[0].color[2], 30);

  ASSERT_EQ(counts.parts.size(), 2u);
  EXPECT_FALSE(std::filesystem::exists(dir / "parts" / "7"));
  const PartExport& first = counts.parts[0];
  EXPECT_EQ(first.number, 1);
  EXPECT_EQ(first.submaps, (std::vector<std::uint32_t>{2, 3}));
  EXPECT_EQ(first.first_frame, 20);
  EXPECT_EQ(first.last_frame, 44);
  EXPECT_EQ(first.frames_posed, 10);
  EXPECT_EQ(first.points, 1);
  const std::vector<TimedPose> part_poses = ReadTumTrajectory(dir / "parts" / "1" / "trajectory.tum");
  ASSERT_EQ(part_poses.size(), 10u);
  EXPECT_NEAR(part_poses[0].timestamp, 2.0, 1e-12);
  EXPECT_NEAR(part_poses[0].world_from_cam.translation().x(), 5.0, 1e-9);  // submap 2, part frame
  EXPECT_NEAR(part_poses[5].timestamp, 4.0, 1e-12);
  EXPECT_NEAR(part_poses[5].world_from_cam.translation().x(), 3.0, 1e-9);  // 3 x 1.0 from submap 3
  EXPECT_NEAR(part_poses[5].world_from_cam.translation().y(), 10.0, 1e-9);
  EXPECT_EQ(ReadPlyPoints(dir / "parts" / "1" / "points.ply").size(), 1u);
  const PartExport& second = counts.parts[1];
  EXPECT_EQ(second.number, 2);
  EXPECT_EQ(second.submaps, (std::vector<std::uint32_t>{4}));
  EXPECT_EQ(second.frames_posed, 5);
  EXPECT_EQ(ReadTumTrajectory(dir / "parts" / "2" / "trajectory.tum").size(), 5u);
  EXPECT_TRUE(ReadPlyPoints(dir / "parts" / "2" / "points.ply").empty());

  // A run without disconnected parts leaves no parts/ folder.
  snapshot.submaps.resize(2);
  EXPECT_TRUE(ExportWorldMap(snapshot, dir / "submaps", dir, 10.0).parts.empty());
  EXPECT_FALSE(std::filesystem::exists(dir / "parts"));
  std::filesystem::remove_all(dir);
}

TEST(MapExport, ReportListsPartsAndCountsTheirFramesAsPosedElsewhere) {
  MappingReport r;
  r.frames_decoded = 600;
  r.submaps = 4;
  r.frames_posed = 541;
  r.frames_unposed = 59;
  PartExport part;
  part.number = 1;
  part.submaps = {0};
  part.first_frame = 0;
  part.last_frame = 58;
  part.frames_posed = 59;
  part.points = 239;
  r.parts.push_back(part);
  const std::vector<std::string> warnings = Diagnose(r, 20);
  ASSERT_EQ(warnings.size(), 1u);  // the 59 frames are in parts/1, not "could not be posed"
  EXPECT_NE(warnings[0].find("1 part of the flight (59 frames)"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("parts/<n>/"), std::string::npos) << warnings[0];
  const nlohmann::json parts = r.ToJson().at("parts");
  ASSERT_EQ(parts.size(), 1u);
  EXPECT_EQ(parts[0].at("directory"), "parts/1");
  EXPECT_EQ(parts[0].at("frames_posed"), 59);
  EXPECT_EQ(parts[0].at("submaps"), nlohmann::json::array({0}));
  // Frames neither in the map nor in a part are still reported as unposed.
  r.frames_decoded = 700;
  r.frames_unposed = 159;
  ASSERT_EQ(Diagnose(r, 20).size(), 2u);
  EXPECT_NE(Diagnose(r, 20)[0].find("100 of 700 frames could not be posed"), std::string::npos)
      << Diagnose(r, 20)[0];
  r.parts.clear();
  ASSERT_EQ(Diagnose(r, 20).size(), 1u);
  EXPECT_NE(Diagnose(r, 20)[0].find("159 of 700"), std::string::npos) << Diagnose(r, 20)[0];
}

}  // namespace
}  // namespace glam
