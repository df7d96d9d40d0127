// The final submap's extension (SubmapOptions::extend_short_final_submap and
// short_final_submap_fraction): a submap closed by the end of input with fewer keyframes than
// the fraction of keyframes_per_submap is tracked again from a keyframe of the previous
// submap, which gives it more baseline and views and so a better map; a final submap at or
// above the fraction is left as the paper builds it.
//
// Clip: the synthetic lawnmower (300 frames, 640x360, 100 m, seed 1) with 6 keyframes per
// submap, whose final submap closes with 4 keyframes (4/6 = 0.67): extended at the default
// fraction 0.75, not at 0.5. The earlier submaps are the same either way.
#include <cstdio>

#include <gtest/gtest.h>

#include "tests/support/clip_runner.h"
#include "tests/support/submap_accuracy.h"
#include "tools/eval/ground_truth_surface.h"

namespace glam {
namespace {

TEST(FinalSubmapExtension, ExtendsOnlyAShortFinalSubmapAndThatMakesItsMapBetter) {
  const test_support::ClipTruth clip =
      test_support::LoadClipTruth(std::filesystem::path(GLAM_TEST_FIXTURES_DIR) / "lawnmower_small");
  SubmapOptions options;
  options.keyframes_per_submap = 6;
  options.bundle_adjustment.refine_focal = false;
  options.bundle_adjustment.refine_k1 = false;
  ASSERT_TRUE(options.extend_short_final_submap);
  ASSERT_DOUBLE_EQ(options.short_final_submap_fraction, 0.75);
  const test_support::ClipRun extended = test_support::RunSubmapBuilderOnClip(clip.video, clip.intrinsics, options, 0);
  options.short_final_submap_fraction = 0.5;
  const test_support::ClipRun kept = test_support::RunSubmapBuilderOnClip(clip.video, clip.intrinsics, options, 0);

  ASSERT_GE(kept.submaps.size(), 2u);
  ASSERT_EQ(extended.submaps.size(), kept.submaps.size());
  const std::size_t last = kept.submaps.size() - 1;
  for (std::size_t i = 0; i < last; ++i) {
    EXPECT_EQ(extended.submaps[i].first_frame, kept.submaps[i].first_frame) << "submap " << i;
    EXPECT_EQ(extended.submaps[i].keyframes.size(), kept.submaps[i].keyframes.size()) << "submap " << i;
  }
  const Submap& previous = kept.submaps[last - 1];
  const Submap& short_final = kept.submaps[last];
  const Submap& long_final = extended.submaps[last];

  // The unextended final submap is short by the default rule but not by the 0.5 one, so the
  // two runs differ only in the rule.
  const double keyframes = static_cast<double>(short_final.keyframes.size());
  ASSERT_LT(keyframes, 0.75 * options.keyframes_per_submap);
  ASSERT_GE(keyframes, 0.5 * options.keyframes_per_submap);
  // Unextended, it starts in the previous submap's overlap (its last ~10 % of frames);
  // extended, earlier, at one of the previous submap's keyframes, and it has more keyframes.
  const double previous_span = static_cast<double>(previous.last_frame - previous.first_frame);
  EXPECT_GE(static_cast<double>(short_final.first_frame), previous.last_frame - 0.2 * previous_span);
  EXPECT_LT(long_final.first_frame, short_final.first_frame);
  EXPECT_GT(long_final.first_frame, previous.first_frame);
  bool starts_at_a_keyframe = false;
  for (const Keyframe& k : previous.keyframes) starts_at_a_keyframe |= k.frame_index == long_final.first_frame;
  EXPECT_TRUE(starts_at_a_keyframe) << "extended final submap starts at frame " << long_final.first_frame;
  EXPECT_GT(long_final.keyframes.size(), short_final.keyframes.size());
  EXPECT_EQ(long_final.last_frame, short_final.last_frame);

  const test_support::SubmapAccuracy short_accuracy = test_support::MeasureSubmap(short_final, clip.gt_world_from_cam, clip.surface);
  const test_support::SubmapAccuracy long_accuracy = test_support::MeasureSubmap(long_final, clip.gt_world_from_cam, clip.surface);
  const double short_median = test_support::MedianOf(short_accuracy.point_errors);
  const double long_median = test_support::MedianOf(long_accuracy.point_errors);
  std::printf("final submap unextended: frames %lld-%lld, %zu keyframes, ATE %.3f m, map median %.3f m\n",
              static_cast<long long>(short_final.first_frame), static_cast<long long>(short_final.last_frame),
              short_final.keyframes.size(), short_accuracy.ate, short_median);
  std::printf("final submap extended:   frames %lld-%lld, %zu keyframes, ATE %.3f m, map median %.3f m\n",
              static_cast<long long>(long_final.first_frame), static_cast<long long>(long_final.last_frame),
              long_final.keyframes.size(), long_accuracy.ate, long_median);
  EXPECT_LT(long_median, short_median);
}

}  // namespace
}  // namespace glam
