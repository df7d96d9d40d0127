// A drone that stops, hovers and yaws in place (SynthOptions::stop_every) gives frame pairs
// without a baseline. Tracking is lost when the yaw turns the camera to unseen ground, and the
// new submap's bootstrap must wait for the drone to move: the essential matrix of a pure
// rotation is degenerate and triangulates invented parallax (engine/geometry/rotation_only.h).
// Ground truth: the fixture's own trajectory and surface (`glam eval`).
#include <filesystem>
#include <map>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "tests/support/mapped_fixture.h"

namespace glam {
namespace {

namespace fs = std::filesystem;

const fs::path kClip = fs::path(GLAM_TEST_FIXTURES_DIR) / "hover_yaw";

struct MappedClip : test_support::MappedFixture {
  bool wrote_parts = false;  // a parts/ directory in the output
};

// Each configuration is mapped once per test process (the two tests share the run without
// rotation-only poses when they run in one process).
const MappedClip& MapAndEvaluate(const MappingOptions& options, const std::string& name) {
  static std::map<std::string, MappedClip> done;
  if (const auto it = done.find(name); it != done.end()) return it->second;
  // These tests compare how thread 1 poses the hovering frames, so the end-of-run global
  // refinement is off: on this clip it lowers the moving frames' error (0.169 -> 0.151 m) and
  // raises the hovering frames' (0.161 -> 0.246 m; docs/algorithm.md, global refinement), in
  // both configurations, which would blur the difference each test is about.
  MappingOptions rigid = options;
  rigid.global_refinement.max_keyframes = 0;
  bool wrote_parts = false;
  test_support::MappedFixture run = test_support::MapFixture(  // uncalibrated: the focal is estimated
      kClip, rigid, false, name, [&](const fs::path& out) { wrote_parts = fs::exists(out / "parts"); });
  return done.emplace(name, MappedClip{std::move(run), wrote_parts}).first->second;
}

MappingOptions WithoutRotationOnlyPoses() {
  MappingOptions options;
  options.submap.hover_max_speed = 0;
  return options;
}

// Tested without the rotation-only poses (next test): with them the yaws' frames stay in the
// submap before the hover and no bootstrap starts there. And with 30-keyframe submaps: the
// first submap then reaches the first hover's tracking loss (at 11 keyframes) before it may
// decide on the camera (half of keyframes_per_submap), so the focal is still unsettled when the
// second hover is bootstrapped, the case the check is for. With 20-keyframe submaps the loss
// settles the focal (554 px, truth 554) and both runs map alike (ATE 0.143 m, 86.9 % posed):
// at the true focal a pure rotation shows no parallax to E either.
MappingOptions UnsettledAtTheHover() {
  MappingOptions options = WithoutRotationOnlyPoses();
  options.submap.keyframes_per_submap = 30;
  return options;
}

TEST(HoverYaw, NoSubmapStartsOnAPureRotation) {
  const eval::EvaluationResult& with_veto = MapAndEvaluate(UnsettledAtTheHover(), "unsettled").result;
  ASSERT_TRUE(with_veto.map.has_value());
  // Measured: ATE 0.232 m, map median 0.256 m, 87.0 % of the 1200 frames posed (the yaws to
  // unseen ground cannot be) at 60 m, 45 deg oblique.
  EXPECT_LT(with_veto.trajectory.ate_rmse, 0.35);
  EXPECT_LT(with_veto.map->median, 0.35);
  EXPECT_GT(with_veto.trajectory.fraction_posed, 0.8);

  // The control: the same clip without the rotation check bootstraps a submap on two frames
  // of the second hover, whose invented geometry is either placed metres wrong (measured ATE
  // 1.86 m, map median 0.72 m) or cannot be linked to the map at all (measured 2026-12-07:
  // 66.0 % posed instead of 87.0 %); which of the two depends on details far from the
  // bootstrap. If neither holds, the clip no longer tests the case.
  MappingOptions paper_bootstrap = UnsettledAtTheHover();
  paper_bootstrap.submap.bootstrap_rotation_veto_fraction = 0;
  const eval::EvaluationResult& without = MapAndEvaluate(paper_bootstrap, "no_veto").result;
  const bool placed_wrong = without.trajectory.ate_rmse > 3 * with_veto.trajectory.ate_rmse;
  const bool lost = without.trajectory.fraction_posed < with_veto.trajectory.fraction_posed - 0.15;
  EXPECT_TRUE(placed_wrong || lost) << "without the veto: ATE " << without.trajectory.ate_rmse << " m, "
                                    << without.trajectory.fraction_posed * 100 << " % posed";
}

// SubmapOptions::hover_max_speed: the frames of each hovering yaw to unseen ground are posed by
// rotation only, at the hover's centre, instead of being lost. Control: without it they are
// not posed at all.
TEST(HoverYaw, YawsToUnseenGroundArePosedByRotationOnly) {
  const MappedClip& without_run = MapAndEvaluate(WithoutRotationOnlyPoses(), "no_rotation_only");
  const MappedClip& with_run = MapAndEvaluate(MappingOptions(), "default");
  const eval::EvaluationResult& without = without_run.result;
  const eval::EvaluationResult& with = with_run.result;
  ASSERT_TRUE(with.map.has_value());
  // Measured: 86.9 % -> 97.8 % posed, ATE 0.143 -> 0.127 m, map median 0.230 -> 0.198 m
  // (2026-12-07; first measured 87.0 -> 97.8 %, 0.22 -> 0.17 m): the chains hold the hover's
  // centre (the drone does not move), so they add frames, not error.
  EXPECT_LT(without.trajectory.fraction_posed, 0.9);
  EXPECT_GT(with.trajectory.fraction_posed, 0.95);
  EXPECT_LT(with.trajectory.ate_rmse, without.trajectory.ate_rmse * 1.1);
  EXPECT_LT(with.map->median, 0.35);
  // report.json counts them (measured 146 over the three yaws).
  const MappingReport& report = with_run.report;
  EXPECT_EQ(without_run.report.frames_rotation_only, 0);
  EXPECT_GT(report.frames_rotation_only, 90);
  EXPECT_LT(report.frames_rotation_only, 300);
  // The submap bootstrapped across the second yaw (frames 576-641: a frame before the yaw and
  // one after it) was left without landmarks by its completion filters and is discarded
  // instead of becoming a part of the flight without points (it did, before 2026-12-07).
  EXPECT_EQ(report.disconnected_submaps, 0);
  EXPECT_GE(report.submaps_discarded, 1);
  EXPECT_FALSE(with_run.wrote_parts);
}

}  // namespace
}  // namespace glam
