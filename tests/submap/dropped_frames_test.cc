// Frames missing from the sequence (a live stream that dropped them: StreamSource numbers
// frames by their timestamps, so the gaps show in the indices and times the builder sees).
// Tracking predicts each frame's pose at its own time (engine/submap/motion_prediction.h), so
// after a gap guided matching still searches where the landmarks are, instead of one frame's
// motion behind them and then falling back to matching against every landmark. On the loop
// fixture (15 fps, 40 m: ~8-10 px of image motion per frame) with bursts of dropped frames,
// every frame after a gap must be tracked guided, and the submaps stay as accurate as the
// complete clip's.
#include <cmath>
#include <cstdio>
#include <set>

#include <gtest/gtest.h>

#include "engine/core/se3.h"
#include "engine/submap/motion_prediction.h"
#include "tests/support/clip_runner.h"
#include "tests/support/submap_accuracy.h"

namespace glam {
namespace {

SE3 ScrewPose(double t) {
  // A camera turning at 0.3 rad/s about a tilted axis while flying 12 m/s (cam_from_world).
  Vector6d xi;
  xi << 12.0 * t, 1.5 * t, -0.4 * t, 0.05 * t, -0.1 * t, 0.3 * t;
  return SE3::Exp(xi);
}

double PoseDistance(const SE3& a, const SE3& b) {
  return (a * b.Inverse()).Log().norm();
}

TEST(MotionPrediction, ExtrapolatesAConstantScrewMotionAcrossAGap) {
  const SE3 before = ScrewPose(1.0), last = ScrewPose(1.1);
  // Equal steps: exactly the product, as before time entered the prediction.
  const SE3 next = ExtrapolateConstantVelocity(before, 1.0, last, 1.1, 1.2);
  EXPECT_LT(PoseDistance(next, (last * before.Inverse()) * last), 1e-12);
  EXPECT_LT(PoseDistance(next, ScrewPose(1.2)), 1e-9);
  // Four frames dropped: the prediction is five steps on, where the camera is.
  EXPECT_LT(PoseDistance(ExtrapolateConstantVelocity(before, 1.0, last, 1.1, 1.6), ScrewPose(1.6)), 1e-9);
  // One step of motion would have been far off.
  EXPECT_GT(PoseDistance(next, ScrewPose(1.6)), 1.0);
  // A gap between the two posed frames (unposed frames between them): the velocity is per second.
  EXPECT_LT(PoseDistance(ExtrapolateConstantVelocity(ScrewPose(0.5), 0.5, last, 1.1, 1.3), ScrewPose(1.3)), 1e-9);
}

TEST(MotionPrediction, ClampsLongGapsAndIgnoresBadTimes) {
  const SE3 before = ScrewPose(0.0), last = ScrewPose(0.1);
  // Beyond kMaxExtrapolationSteps the prediction stops.
  const SE3 far = ExtrapolateConstantVelocity(before, 0.0, last, 0.1, 100.0);
  EXPECT_LT(PoseDistance(far, ScrewPose(0.1 + 0.1 * kMaxExtrapolationSteps)), 1e-9);
  // A frame at the last frame's time stays there.
  EXPECT_LT(PoseDistance(ExtrapolateConstantVelocity(before, 0.0, last, 0.1, 0.1), last), 1e-12);
  // Times that do not increase count as one step.
  const SE3 one_step = (last * before.Inverse()) * last;
  EXPECT_LT(PoseDistance(ExtrapolateConstantVelocity(before, 0.1, last, 0.1, 0.5), one_step), 1e-12);
  EXPECT_LT(PoseDistance(ExtrapolateConstantVelocity(before, 0.0, last, 0.1, std::nan("")), one_step), 1e-12);
}

TEST(DroppedFrames, FramesAfterAGapAreTrackedWhereTheCameraIsByThen) {
  const test_support::ClipTruth clip =
      test_support::LoadClipTruth(std::filesystem::path(GLAM_TEST_FIXTURES_DIR) / "loop");
  SubmapOptions options;
  options.bundle_adjustment.refine_focal = false;
  options.bundle_adjustment.refine_k1 = false;
  // Bursts of 4 dropped frames (0.27 s at 15 fps) every 30 frames, as a stream over a lossy
  // link delivers them; the first 60 frames complete (the bootstrap is not what is tested).
  auto dropped = [](std::int64_t index) { return index >= 60 && index % 30 >= 25; };
  const test_support::ClipRun run = test_support::RunSubmapBuilderOnClip(
      clip.video, clip.intrinsics, options, 0, -1, SiftOptions(), dropped);
  const test_support::RunAccuracy accuracy = test_support::MeasureSubmaps(run.submaps, clip);
  std::set<std::int64_t> posed;  // frames shared by two submaps count once
  for (const Submap& s : run.submaps) {
    for (const FramePose& fp : s.frame_poses) posed.insert(fp.frame_index);
  }
  std::printf("%lld frames fed, %zu posed, %lld matched globally, %lld tracking losses, "
              "%zu submaps, mean per-submap ATE %.3f m, map median %.3f m\n",
              static_cast<long long>(run.frames), posed.size(), static_cast<long long>(run.stats.frames_matched_globally),
              static_cast<long long>(run.stats.tracking_losses), accuracy.submaps, accuracy.mean_submap_ate,
              accuracy.map_median);
  EXPECT_EQ(run.stats.tracking_losses, 0);
  // With one step of motion predicted across each gap, 15 frames fell back (the submaps' mean
  // ATE 0.043 m against 0.035 m, and the run took 30 % longer).
  EXPECT_LE(run.stats.frames_matched_globally, 2);
  EXPECT_GE(static_cast<double>(posed.size()), 0.98 * static_cast<double>(run.frames));
  EXPECT_LT(accuracy.mean_submap_ate, 0.1);
}

}  // namespace
}  // namespace glam
