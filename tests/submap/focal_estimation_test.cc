// Focal length estimation end to end (issue 4): on a 600-frame oblique loop (30 degrees from
// nadir, 8 m relief under 60 m altitude; fixture synth_oblique_relief) the submap builder is
// started with a focal 10 % too long and refines it (per-keyframe focals in bundle
// adjustment, running median); the estimate must land within 1 % of the truth.
#include <cmath>
#include <cstdio>
#include <set>

#include <gtest/gtest.h>

#include "engine/core/intrinsics_io.h"
#include "engine/core/logging.h"
#include "engine/features/sift_extractor.h"
#include "engine/submap/submap_builder.h"
#include "engine/video/frame_source.h"

namespace glam {
namespace {

TEST(FocalEstimation, FocalStartedTenPercentLongConvergesWithinOnePercent) {
  if (const char* level = std::getenv("GLAM_LOG_LEVEL")) InitLogging(level);
  const std::filesystem::path dir = std::filesystem::path(GLAM_TEST_FIXTURES_DIR) / "oblique_relief";
  const Intrinsics truth = ReadIntrinsicsJson(dir / "intrinsics.json");
  Intrinsics guess = truth;
  guess.fx *= 1.1;
  guess.fy *= 1.1;

  SubmapOptions options;  // paper defaults: 20 keyframes per submap, focal refined
  ASSERT_TRUE(options.bundle_adjustment.refine_focal);
  SubmapBuilder builder(guess, options);
  SiftExtractor sift;
  auto source = OpenFrameSource(dir / "video.mp4");
  std::set<std::int64_t> posed;
  std::size_t submaps = 0;
  auto collect = [&](std::vector<Submap> done) {
    for (const Submap& s : done) {
      ++submaps;
      for (const FramePose& fp : s.frame_poses) posed.insert(fp.frame_index);
    }
  };
  while (auto frame = source->Next()) {
    collect(builder.AddFrame(frame->index, frame->timestamp_s, sift.Extract(frame->bgr)));
  }
  collect(builder.Finish());
  const std::int64_t frames = source->frames_delivered();
  ASSERT_EQ(frames, 600);

  const double error = (builder.focal() - truth.fx) / truth.fx;
  std::printf("focal: started %.1f px, estimated %.1f px, truth %.1f px (%+.2f %%); %zu submaps, %zu/%lld frames posed\n",
              guess.fx, builder.focal(), truth.fx, 100.0 * error, submaps, posed.size(),
              static_cast<long long>(frames));
  // The estimate is only meaningful if the clip was actually mapped.
  EXPECT_GE(static_cast<double>(posed.size()) / static_cast<double>(frames), 0.95);
  EXPECT_LT(std::abs(error), 0.01);
}

}  // namespace
}  // namespace glam
