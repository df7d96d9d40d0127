// Focal length estimation end to end (issue 4): started 10 % too long, the submap builder
// refines the focal (one focal per bundle adjustment, weak prior at the running median; a
// submap whose focal moved more than 2 % is rebuilt at the new focal) and must land within
// 1 % of the truth, while the submaps built on the way stay accurate: a focal that is right
// in the end but mapped the first frames bent (measured before the rebuild existed: 25 m
// trajectory error on the high clip) or a short last submap that drags its own focal away
// (measured before the prior grew with completed keyframes: 16 %, 3.7 m) must fail here.
//
// Two oblique loops, 30 degrees from nadir, relief >= 10 % of the altitude (on flat nadir
// footage focal trades off against altitude, so that case is not a fair test):
//  * oblique_relief: 60 m, 8 m relief, 15 fps, SIFT on every frame (the paper's features),
//    several submaps;
//  * oblique_high: 100 m, 15 m relief, 30 fps, the product's feature stage (DecoderWorker,
//    KLT between detections): slow parallax, one long first submap.
#include <cmath>
#include <cstdio>
#include <set>

#include <gtest/gtest.h>

#include "engine/core/intrinsics_io.h"
#include "engine/core/similarity_alignment.h"
#include "engine/export/tum_trajectory.h"
#include "engine/features/sift_extractor.h"
#include "engine/submap/submap_builder.h"
#include "engine/video/frame_source.h"
#include "tests/support/clip_runner.h"

namespace glam {
namespace {

std::filesystem::path FixtureDir(const char* name) {
  return std::filesystem::path(GLAM_TEST_FIXTURES_DIR) / name;
}

Intrinsics TenPercentLong(const Intrinsics& truth) {
  Intrinsics guess = truth;
  guess.fx *= 1.1;
  guess.fy *= 1.1;
  return guess;
}

// Checks the outcome of one run: focal within 1 %, >= 95 % of the frames posed, and every
// submap's trajectory within `max_ate` (m) of the truth after its own Sim3.
void ExpectAccurate(const std::vector<Submap>& submaps, double focal, std::int64_t frames,
                    const std::filesystem::path& dir, double max_ate) {
  const Intrinsics truth = ReadIntrinsicsJson(dir / "intrinsics.json");
  const std::vector<TimedPose> gt = ReadTumTrajectory(dir / "gt_trajectory.tum");
  ASSERT_EQ(frames, static_cast<std::int64_t>(gt.size()));
  std::set<std::int64_t> posed;
  for (const Submap& s : submaps) {
    std::vector<Eigen::Vector3d> estimated, true_centres;
    for (const FramePose& fp : s.frame_poses) {
      posed.insert(fp.frame_index);
      estimated.push_back(fp.cam_from_submap.Inverse().translation());
      true_centres.push_back(gt[static_cast<std::size_t>(fp.frame_index)].world_from_cam.translation());
    }
    const double ate = AlignSimilarity(estimated, true_centres).rmse;
    std::printf("submap %u: frames %lld-%lld, %zu keyframes, ATE %.3f m\n", s.id,
                static_cast<long long>(s.first_frame), static_cast<long long>(s.last_frame),
                s.keyframes.size(), ate);
    EXPECT_LT(ate, max_ate) << "submap " << s.id;
  }
  const double error = (focal - truth.fx) / truth.fx;
  std::printf("focal: started %.1f px, estimated %.1f px, truth %.1f px (%+.2f %%); %zu submaps, %zu/%lld frames posed\n",
              TenPercentLong(truth).fx, focal, truth.fx, 100.0 * error, submaps.size(), posed.size(),
              static_cast<long long>(frames));
  // The estimate is only meaningful if the clip was actually mapped.
  EXPECT_GE(static_cast<double>(posed.size()) / static_cast<double>(frames), 0.95);
  EXPECT_LT(std::abs(error), 0.01);
}

TEST(FocalEstimation, StartedTenPercentLongConvergesWithinOnePercentOverSeveralSubmaps) {
  const std::filesystem::path dir = FixtureDir("oblique_relief");
  SubmapOptions options;  // defaults: 20 keyframes per submap, focal refined
  ASSERT_TRUE(options.bundle_adjustment.refine_focal);
  SubmapBuilder builder(TenPercentLong(ReadIntrinsicsJson(dir / "intrinsics.json")), options);
  SiftExtractor sift;
  auto source = OpenFrameSource(dir / "video.mp4");
  std::vector<Submap> submaps;
  auto collect = [&](std::vector<Submap> done) {
    for (Submap& s : done) submaps.push_back(std::move(s));
  };
  while (auto frame = source->Next()) {
    collect(builder.AddFrame(frame->index, frame->timestamp_s, sift.Extract(frame->bgr)));
  }
  collect(builder.Finish());
  ASSERT_GE(submaps.size(), 3u);  // the later submaps start from the estimate
  ExpectAccurate(submaps, builder.focal(), source->frames_delivered(), dir, 0.003 * 60.0);
}

TEST(FocalEstimation, StartedTenPercentLongAtHighAltitudeKeepsTheFirstSubmapRight) {
  const std::filesystem::path dir = FixtureDir("oblique_high");
  SubmapOptions options;
  test_support::ClipRun run = test_support::RunSubmapBuilderOnClip(
      dir / "video.mp4", TenPercentLong(ReadIntrinsicsJson(dir / "intrinsics.json")), options, 0);
  ExpectAccurate(run.submaps, run.focal, run.frames, dir, 0.003 * 100.0);
}

}  // namespace
}  // namespace glam
