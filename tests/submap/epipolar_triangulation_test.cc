// Epipolar matching for triangulation (SubmapOptions::epipolar_triangulation_matching, on with a
// calibration): the middle keyframe / current frame pairs matched along the PnP poses'
// epipolar lines instead of globally + essential RANSAC must give submaps as accurate as the
// paper's matching, with at least as many landmarks (the band finds matches a global ratio test
// calls ambiguous), on the shared calibrated lawnmower clip.
#include <cstdio>

#include <gtest/gtest.h>

#include "tests/support/clip_runner.h"
#include "tests/support/submap_accuracy.h"
#include "tools/eval/ground_truth_surface.h"

namespace glam {
namespace {

struct Accuracy {
  double mean_submap_ate = 0;  // mean over submaps of the frame-centre ATE after Sim3 (m)
  double map_median = 0;       // median landmark distance to the true surface (m)
  std::size_t submaps = 0;
  std::size_t landmarks = 0;
};

Accuracy Measure(const test_support::ClipRun& run, const test_support::ClipTruth& clip) {
  Accuracy out;
  std::vector<double> errors;
  for (const Submap& s : run.submaps) {
    const test_support::SubmapAccuracy a = test_support::MeasureSubmap(s, clip.gt_world_from_cam, clip.surface);
    out.mean_submap_ate += a.ate;
    out.landmarks += s.landmarks.size();
    errors.insert(errors.end(), a.point_errors.begin(), a.point_errors.end());
  }
  out.submaps = run.submaps.size();
  if (out.submaps > 0) out.mean_submap_ate /= static_cast<double>(out.submaps);
  out.map_median = test_support::MedianOf(std::move(errors));
  return out;
}

TEST(EpipolarTriangulation, MatchesAlongEpipolarLinesMapAsWellAsGlobalMatching) {
  const test_support::ClipTruth clip =
      test_support::LoadClipTruth(std::filesystem::path(GLAM_TEST_FIXTURES_DIR) / "lawnmower_small");
  SubmapOptions options;
  options.bundle_adjustment.refine_focal = false;
  options.bundle_adjustment.refine_k1 = false;
  options.epipolar_triangulation_matching = true;
  const Accuracy epipolar = Measure(test_support::RunSubmapBuilderOnClip(clip.video, clip.intrinsics, options, 0), clip);
  options.epipolar_triangulation_matching = false;
  const Accuracy global = Measure(test_support::RunSubmapBuilderOnClip(clip.video, clip.intrinsics, options, 0), clip);
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
