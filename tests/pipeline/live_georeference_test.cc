// LiveGeoreferencer on a flight with a known east-north-up truth: two submaps in a mapping
// frame that differs from ENU by a similarity, GPS positions at every frame's time. A revision
// is left as it is until the posed track allows a fit, then put in ENU (same revision number,
// ecef_from_world set); a later revision whose refit fails keeps the last fit instead of going
// back to the mapping frame; submaps never passed to AddSubmap (an interrupted run's) are read
// from disk.
#include "engine/pipeline/live_georeference.h"

#include <cmath>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "engine/core/placed_pose.h"
#include "engine/geo/geodetic.h"
#include "engine/map/submap_io.h"
#include "engine/pipeline/map_export.h"
#include "tests/pipeline/posed_submap.h"
#include "tests/support/temp_dir.h"

namespace glam {
namespace {

constexpr double kFps = 10;
const Geodetic kOrigin{50.8, -0.1, 20.0};

// True camera centre (ENU, metres) of frame i: a 60 m leg east, then 40 m north.
Eigen::Vector3d TrueCentre(std::int64_t i) {
  const double d = static_cast<double>(i);
  return i < 60 ? Eigen::Vector3d(d, 0, 40) : Eigen::Vector3d(60, d - 60, 40);
}

// The mapping frame: what the map would be in without GPS (arbitrary scale, heading, origin).
const Sim3 kWorldFromEnu(0.05, SO3::Exp(Eigen::Vector3d(0.02, -0.01, 1.1)), Eigen::Vector3d(3, -2, 1));

// A submap posing frames [first, last] of the flight, its own frame placed in the mapping frame.
Submap PosedSubmap(std::uint32_t id, std::int64_t first, std::int64_t last, const Sim3& world_from_submap) {
  const Sim3 submap_from_enu = world_from_submap.Inverse() * kWorldFromEnu;
  return glam::testing::PosedSubmap(id, first, last,
                                    [&](std::int64_t i) { return Eigen::Vector3d(submap_from_enu * TrueCentre(i)); });
}

std::vector<GpsSample> GpsTrack(std::int64_t frames) {
  const EnuFrame enu(kOrigin);
  std::vector<GpsSample> gps;
  for (std::int64_t i = 0; i < frames; ++i) {
    // The track's first fix is the ENU origin of every fit: shift so frame 0 is at the origin.
    gps.push_back({static_cast<double>(i) / kFps, enu.GeodeticFromEnu(TrueCentre(i) - TrueCentre(0))});
  }
  return gps;
}

SubmapPlacement Placement(const Submap& s, const Sim3& world_from_submap, bool disconnected = false) {
  SubmapPlacement p;
  p.id = s.id;
  p.world_from_submap = world_from_submap;
  p.part_from_submap = world_from_submap;
  p.first_frame = s.first_frame;
  p.last_frame = s.last_frame;
  p.disconnected = disconnected;
  p.part = disconnected ? 1 : 0;
  return p;
}

// Largest distance between a revision's camera centres (placed by its snapshot) and the truth.
double WorstCentreError(const MapSnapshot& snapshot, const std::vector<const Submap*>& submaps) {
  double worst = 0;
  for (const Submap* s : submaps) {
    for (const SubmapPlacement& p : snapshot.submaps) {
      if (p.id != s->id) continue;
      for (const FramePose& fp : s->frame_poses) {
        const Eigen::Vector3d centre = WorldFromCam(p.world_from_submap, fp.cam_from_submap).translation();
        worst = std::max(worst, (centre - (TrueCentre(fp.frame_index) - TrueCentre(0))).norm());
      }
    }
  }
  return worst;
}

TEST(LiveGeoreferencer, PutsRevisionsInEnuOnceTheTrackAllowsAFitAndKeepsTheFitAfterwards) {
  const std::filesystem::path root = glam::testing::FreshTempDir("live_georeference") / "submaps";
  const Sim3 world_from_s0;  // the first submap is the mapping frame
  const Sim3 world_from_s1(1.7, SO3::Exp(Eigen::Vector3d(0, 0.1, -0.4)), Eigen::Vector3d(1, 2, 0.5));
  const Submap s0_short = PosedSubmap(0, 0, 5, world_from_s0);  // 6 frames over 5 m
  const Submap s0 = PosedSubmap(0, 0, 64, world_from_s0);
  const Submap s1 = PosedSubmap(1, 58, 99, world_from_s1);
  LiveGeoreferencer live(GpsTrack(100), kFps, GeoreferenceOptions{}, root);

  // Too little track for a fit: the revision is handed on as it is.
  live.AddSubmap(s0_short);
  auto first = std::make_shared<MapSnapshot>();
  first->revision = 1;
  first->submaps = {Placement(s0_short, world_from_s0)};
  EXPECT_EQ(live.Apply(first), first);
  EXPECT_FALSE(live.fit().has_value());

  // Both submaps (the first one completed again with more frames replaces the short one).
  live.AddSubmap(s0);
  live.AddSubmap(s1);
  auto second = std::make_shared<MapSnapshot>();
  second->revision = 2;
  second->submaps = {Placement(s0, world_from_s0), Placement(s1, world_from_s1)};
  const std::shared_ptr<const MapSnapshot> enu = live.Apply(second);
  ASSERT_TRUE(live.fit().has_value());
  EXPECT_EQ(enu->revision, 2);
  ASSERT_TRUE(enu->ecef_from_world.has_value());
  EXPECT_LT((*enu->ecef_from_world - EnuFrame(kOrigin).EcefFromEnu()).norm(), 1e-6);
  EXPECT_LT(WorstCentreError(*enu, {&s0, &s1}), 1e-3);
  EXPECT_NEAR(live.fit()->enu_from_world.scale(), 1 / kWorldFromEnu.scale(), 1e-6);
  // The input snapshot is not changed (readers may hold it).
  EXPECT_FALSE(second->ecef_from_world.has_value());
  EXPECT_GT(WorstCentreError(*second, {&s0, &s1}), 10.0);

  // A revision whose refit fails (here: a map of 4 frames over 3 m) keeps the last fit.
  const Submap tiny = PosedSubmap(2, 20, 23, world_from_s0);
  live.AddSubmap(tiny);
  auto third = std::make_shared<MapSnapshot>();
  third->revision = 3;
  third->submaps = {Placement(tiny, world_from_s0)};
  const std::shared_ptr<const MapSnapshot> kept = live.Apply(third);
  EXPECT_EQ(kept->revision, 3);
  ASSERT_TRUE(kept->ecef_from_world.has_value());
  EXPECT_LT(WorstCentreError(*kept, {&tiny}), 1e-3);
}

// A part the images could not link to the map (its placement in the snapshot only a guess) is
// placed by a GPS fit of its own, as the final revision places it, and shown connected.
TEST(LiveGeoreferencer, PlacesADisconnectedPartByItsOwnFit) {
  const std::filesystem::path root = glam::testing::FreshTempDir("live_georeference_part") / "submaps";
  // The part (frames 80-99: 20 m north) is a straight line, so its fit is yaw, scale and offset
  // in its levelled frame; a submap without landmarks levels to its own frame, so that frame is
  // made level here (the map's, frames 0-79 over both directions, gets the full fit). The part's
  // first submap is levelled from its file, as in a run (submaps are persisted before alignment).
  const Sim3 enu_from_s1(1.7, SO3::Exp(Eigen::Vector3d(0, 0, 0.7)), Eigen::Vector3d(5, 3, 0));
  const Sim3 world_from_s1 = kWorldFromEnu * enu_from_s1;
  const Submap s0 = PosedSubmap(0, 0, 79, Sim3());
  const Submap s1 = PosedSubmap(1, 80, 99, world_from_s1);
  WriteSubmap(s1, root);
  LiveGeoreferencer live(GpsTrack(100), kFps, GeoreferenceOptions{}, root);
  live.AddSubmap(s0);
  live.AddSubmap(s1);
  auto snapshot = std::make_shared<MapSnapshot>();
  snapshot->revision = 4;
  // s1 is a part of its own: its guessed world placement is wrong, its part frame is itself.
  snapshot->submaps = {Placement(s0, Sim3()), Placement(s1, Sim3(), true)};
  snapshot->submaps[1].part_from_submap = Sim3();
  const std::shared_ptr<const MapSnapshot> enu = live.Apply(snapshot);
  ASSERT_TRUE(live.fit().has_value());
  EXPECT_FALSE(enu->submaps[1].disconnected);
  EXPECT_EQ(enu->submaps[1].part, 0);
  EXPECT_LT(WorstCentreError(*enu, {&s0, &s1}), 1e-3);
  EXPECT_TRUE(snapshot->submaps[1].disconnected);  // the input is untouched
}

TEST(LiveGeoreferencer, ReadsSubmapsItWasNotGivenFromDisk) {
  const std::filesystem::path root = glam::testing::FreshTempDir("live_georeference_resume") / "submaps";
  const Sim3 world_from_s1(0.6, SO3::Exp(Eigen::Vector3d(0.05, 0, 0.3)), Eigen::Vector3d(-1, 0, 2));
  const Submap s0 = PosedSubmap(0, 0, 64, Sim3());
  const Submap s1 = PosedSubmap(1, 58, 99, world_from_s1);
  WriteSubmap(s0, root);  // completed by the interrupted run
  LiveGeoreferencer live(GpsTrack(100), kFps, GeoreferenceOptions{}, root);
  live.AddSubmap(s1);
  auto snapshot = std::make_shared<MapSnapshot>();
  snapshot->revision = 5;
  snapshot->submaps = {Placement(s0, Sim3()), Placement(s1, world_from_s1)};
  const std::shared_ptr<const MapSnapshot> enu = live.Apply(snapshot);
  ASSERT_TRUE(live.fit().has_value()) << "no fit";
  EXPECT_EQ(live.fit()->samples_matched, 100);
  EXPECT_LT(WorstCentreError(*enu, {&s0, &s1}), 1e-3);
}

}  // namespace
}  // namespace glam
