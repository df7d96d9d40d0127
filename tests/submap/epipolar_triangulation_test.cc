// Epipolar matching for triangulation (SubmapOptions::epipolar_triangulation_matching, on with a
// calibration): the middle keyframe / current frame pairs matched along the PnP poses'
// epipolar lines instead of globally + essential RANSAC must give submaps as accurate as the
// paper's matching, with at least as many landmarks (the band finds matches a global ratio test
// calls ambiguous), on the shared calibrated lawnmower clip.
#include <cstdio>

#include <gtest/gtest.h>

#include "tests/support/clip_runner.h"
#include "tests/support/submap_accuracy.h"

namespace glam {
namespace {

TEST(EpipolarTriangulation, MatchesAlongEpipolarLinesMapAsWellAsGlobalMatching) {
  const test_support::ClipTruth clip =
      test_support::LoadClipTruth(std::filesystem::path(GLAM_TEST_FIXTURES_DIR) / "lawnmower_small");
  SubmapOptions options;
  options.bundle_adjustment.refine_focal = false;
  options.bundle_adjustment.refine_k1 = false;
  options.epipolar_triangulation_matching = true;
  const test_support::RunAccuracy epipolar =
      test_support::MeasureSubmaps(test_support::RunSubmapBuilderOnClip(clip.video, clip.intrinsics, options, 0).submaps, clip);
  options.epipolar_triangulation_matching = false;
  const test_support::RunAccuracy global =
      test_support::MeasureSubmaps(test_support::RunSubmapBuilderOnClip(clip.video, clip.intrinsics, options, 0).submaps, clip);
  std::printf("epipolar: %zu submaps, %zu landmarks, mean per-submap ATE %.3f m, map median %.3f m\n",
              epipolar.submaps, epipolar.landmarks, epipolar.mean_submap_ate, epipolar.map_median);
  std::printf("global:   %zu submaps, %zu landmarks, mean per-submap ATE %.3f m, map median %.3f m\n",
              global.submaps, global.landmarks, global.mean_submap_ate, global.map_median);
  ASSERT_GE(epipolar.submaps, 1u);
  EXPECT_GE(epipolar.landmarks, global.landmarks);
  EXPECT_LT(epipolar.mean_submap_ate, 1.15 * global.mean_submap_ate + 0.01);
  EXPECT_LT(epipolar.map_median, 1.15 * global.map_median + 0.01);
  EXPECT_LT(epipolar.mean_submap_ate, 0.15);
}

}  // namespace
}  // namespace glam
