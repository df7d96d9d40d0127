// The completion bundle adjustment (SubmapOptions::completion_ba_max_frames): tracked frames
// joining each submap's final BA must make the submap's trajectory more accurate than the
// paper's completion (PnP relocalisation only), and its points no less accurate, on the same
// synthetic lawnmower clip (640x360, 100 m, 6 keyframes per submap, default detection
// schedule).
//
// Why the points are only held to "not more than 10 % worse": with 6 keyframes a submap spans
// ~30-45 m at 100 m altitude, and its map median is dominated by a depth offset along a nearly
// flat direction of the problem (docs/algorithm.md, known limitations) that moves with the
// exact track set. Measured map medians, completion BA against PnP only: 0.534 vs 0.685 m with
// the forward-backward KLT check (the default), 0.435 vs 0.411 m with the patch-correlation
// check (an option); on the benchmark videos (20 keyframes per submap, patch-correlation
// check) the completion BA lowers the map median on the lawnmower (0.115 vs 0.245 m) and
// oblique (0.142 vs 0.152 m) videos and leaves the loop about equal (0.094 vs 0.087 m); it
// lowers the ATE on the lawnmower (0.116 vs 0.161 m) and loop (0.161 vs 0.206 m) and raises it
// on the oblique video (0.112 vs 0.096 m).
#include <algorithm>
#include <cstdio>

#include <gtest/gtest.h>

#include "tests/support/clip_runner.h"
#include "tests/support/submap_accuracy.h"

namespace glam {
namespace {

TEST(CompletionRefinement, TrackedFramesInTheFinalBundleAdjustmentImproveTheSubmaps) {
  const test_support::ClipTruth clip =
      test_support::LoadClipTruth(std::filesystem::path(GLAM_TEST_FIXTURES_DIR) / "lawnmower_small");
  SubmapOptions options;
  options.keyframes_per_submap = 6;
  options.bundle_adjustment.refine_focal = false;
  options.bundle_adjustment.refine_k1 = false;
  ASSERT_GT(options.completion_ba_max_frames, 0) << "the product default uses the completion BA";
  const test_support::RunAccuracy refined =
      test_support::MeasureSubmaps(test_support::RunSubmapBuilderOnClip(clip.video, clip.intrinsics, options, 0).submaps, clip);
  options.completion_ba_max_frames = 0;
  const test_support::RunAccuracy paper =
      test_support::MeasureSubmaps(test_support::RunSubmapBuilderOnClip(clip.video, clip.intrinsics, options, 0).submaps, clip);
  std::printf("completion BA: %zu submaps, mean per-submap ATE %.3f m, map median %.3f m\n", refined.submaps,
              refined.mean_submap_ate, refined.map_median);
  std::printf("PnP only:      %zu submaps, mean per-submap ATE %.3f m, map median %.3f m\n", paper.submaps,
              paper.mean_submap_ate, paper.map_median);
  ASSERT_GE(refined.submaps, 3u);
  ASSERT_EQ(refined.submaps, paper.submaps);  // the refinement happens after the keyframes are chosen
  EXPECT_LT(refined.mean_submap_ate, paper.mean_submap_ate);
  EXPECT_LT(refined.map_median, 1.1 * paper.map_median);
}

}  // namespace
}  // namespace glam
