// The twin check of a focal-dependent first bootstrap (SubmapOptions::bootstrap_twin_*), end
// to end on the oblique60 fixture: a loop 60 degrees from nadir at 40 m. Mapped as a user
// without a calibration would (initial focal 0.8 x 640 = 512 px; truth 554 px), the first two
// keyframes' views give the wrong one of the two motions of nearly planar ground, and the first
// six keyframes built on it adjust to 0.40 px rms; from the motion the views give at 15 % less
// focal the same frames adjust to 0.25 px, and the check must keep that build. (Without the
// check this short clip happens to recover at the first submap's focal rebuild, whose bootstrap
// at 530 px finds the right motion; on bench/robustness.sh's 600-frame pitch60 clip the rebuild
// found the wrong one again: 1.9 m ATE, 68 % posed, 0.08 m and 100 % with the check.)
// Started at the true focal, the check runs too (the views give another motion at 15 % less)
// and must keep the first build.
#include <algorithm>
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "engine/pipeline/mapping_options.h"
#include "engine/submap/submap_builder.h"
#include "tests/support/clip_runner.h"
#include "tests/support/submap_accuracy.h"

namespace glam {
namespace {

const std::filesystem::path kClip = std::filesystem::path(GLAM_TEST_FIXTURES_DIR) / "oblique60";

// The product's guess without a calibration (0.8 x the long side).
Intrinsics UncalibratedGuess(const Intrinsics& truth) {
  Intrinsics guess = truth;
  guess.fx = guess.fy = MappingOptions().default_focal_factor * std::max(truth.width, truth.height);
  return guess;
}

struct Outcome {
  test_support::ClipRun run;
  double focal_error = 0;                      // relative
  double first_submap_ate = 0;                 // m, after the submap's own Sim3
  double first_submap_median_point_error = 0;  // m
};

// Thread 1 over the clip from `start` with the default options (the focal estimated).
Outcome MapClip(const Intrinsics& start) {
  const test_support::ClipTruth truth = test_support::LoadClipTruth(kClip);
  Outcome out;
  out.run = test_support::RunSubmapBuilderOnClip(truth.video, start, SubmapOptions{}, 0);
  out.focal_error = (out.run.focal - truth.intrinsics.fx) / truth.intrinsics.fx;
  if (!out.run.submaps.empty()) {
    const test_support::SubmapAccuracy accuracy =
        test_support::MeasureSubmap(out.run.submaps.front(), truth.gt_world_from_cam, truth.surface);
    out.first_submap_ate = accuracy.ate;
    out.first_submap_median_point_error = test_support::MedianOf(accuracy.point_errors);
  }
  std::printf("started at %.1f px: %lld twin checks, %lld kept; %zu submaps, focal %.1f px (%+.2f %%), first "
              "submap %zu frames, ATE %.3f m, median point error %.3f m\n",
              start.fx, static_cast<long long>(out.run.stats.bootstrap_twin_checks),
              static_cast<long long>(out.run.stats.bootstrap_twins_kept), out.run.submaps.size(), out.run.focal,
              100.0 * out.focal_error,
              out.run.submaps.empty() ? std::size_t{0} : out.run.submaps.front().frame_poses.size(),
              out.first_submap_ate, out.first_submap_median_point_error);
  return out;
}

void ExpectAccurate(const Outcome& outcome) {
  ASSERT_FALSE(outcome.run.submaps.empty());
  EXPECT_GE(outcome.run.submaps.front().frame_poses.size(), 90u);  // of frames 0-98
  EXPECT_LT(std::abs(outcome.focal_error), 0.015);
  EXPECT_LT(outcome.first_submap_ate, 0.1);                 // 0.25 % of the altitude
  EXPECT_LT(outcome.first_submap_median_point_error, 0.5);  // the far field is ~190 m away
}

TEST(BootstrapTwin, AFirstSubmapBootstrappedOnTheWrongMotionIsBuiltAgainFromTheOther) {
  const test_support::ClipTruth truth = test_support::LoadClipTruth(kClip);
  const Outcome guessed = MapClip(UncalibratedGuess(truth.intrinsics));
  EXPECT_EQ(guessed.run.stats.bootstrap_twin_checks, 1);  // once per run: the first submap
  EXPECT_EQ(guessed.run.stats.bootstrap_twins_kept, 1);
  ExpectAccurate(guessed);
}

TEST(BootstrapTwin, ABootstrapOnTheRightMotionKeepsTheFirstBuild) {
  const test_support::ClipTruth truth = test_support::LoadClipTruth(kClip);
  const Outcome started_right = MapClip(truth.intrinsics);  // focal still estimated
  EXPECT_EQ(started_right.run.stats.bootstrap_twin_checks, 1);
  EXPECT_EQ(started_right.run.stats.bootstrap_twins_kept, 0);
  ExpectAccurate(started_right);
}

}  // namespace
}  // namespace glam
