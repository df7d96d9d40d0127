// A run interrupted after some submaps continues from its checkpoint (MappingOptions::resume):
// it starts decoding where the open submap began, keeps the persisted submaps (their files are
// not rewritten), re-aligns them, and ends with a map as accurate as an uninterrupted run.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/videoio.hpp>

#include "engine/core/error.h"
#include "engine/core/intrinsics_io.h"
#include "engine/map/submap_io.h"
#include "engine/pipeline/mapping_job.h"
#include "engine/pipeline/resume_checkpoint.h"
#include "tests/support/exif_photo.h"
#include "tools/eval/evaluation.h"

namespace glam {
namespace {

namespace fs = std::filesystem;

const fs::path kClip = fs::path(GLAM_TEST_FIXTURES_DIR) / "lawnmower_small";

// The content URI of the first child of out/tileset.json.
std::string TilesetContentUri(const fs::path& out) {
  const nlohmann::json tileset = nlohmann::json::parse(std::ifstream(out / "tileset.json"));
  const std::string uri = tileset.at("root").at("children").at(0).at("content").at("uri");
  EXPECT_NE(uri.find("?v="), std::string::npos) << uri;
  return uri;
}

MappingOptions DemoOptions() {
  MappingOptions options;
  options.intrinsics = ReadIntrinsicsJson(kClip / "intrinsics.json");
  options.submap.bundle_adjustment.refine_focal = false;
  options.submap.bundle_adjustment.refine_k1 = false;
  options.submap.keyframes_per_submap = 6;
  // The end-of-run global refinement rewrites every submap and tile once more (under
  // "-refined" tile URIs); off here, so that the checks below can tell persisted submaps and
  // tiles that the resumed run kept from rewritten ones. Refinement has its own tests
  // (tests/pipeline/global_refinement_test.cc).
  options.global_refinement.max_keyframes = 0;
  return options;
}

TEST(ResumeMapping, InterruptedRunContinuesFromItsCheckpointAndIsAccurate) {
  const fs::path out = fs::temp_directory_path() / "glam_resume_test";
  fs::remove_all(out);

  // First run: cancelled as soon as two submaps are on disk.
  CancellationToken cancel;
  std::int64_t first_run_revision = 0;
  auto stop_after_two = [&](const MappingProgress& p) {
    first_run_revision = std::max(first_run_revision, p.revision);
    if (p.submaps_completed >= 2) cancel.Cancel();
  };
  EXPECT_THROW(RunMapping(kClip / "video.mp4", out, DemoOptions(), stop_after_two, cancel), Cancelled);
  const std::optional<ResumeCheckpoint> checkpoint = ReadCheckpoint(out);
  ASSERT_TRUE(checkpoint.has_value());
  EXPECT_GE(checkpoint->next_submap_id, 2u);
  EXPECT_GT(checkpoint->resume_frame, 0);
  EXPECT_EQ(checkpoint->run_id.size(), 16u);
  const fs::file_time_type first_written =
      fs::last_write_time(SubmapDirectory(out / "submaps", 0) / "submap.bin");
  const Submap last_before = ReadSubmap(out / "submaps", checkpoint->next_submap_id - 1);
  // The open submap restarts inside the last one's frames (overlap) or right after them.
  EXPECT_LE(checkpoint->resume_frame, last_before.last_frame + 1);

  // Second run resumes.
  MappingOptions options = DemoOptions();
  options.resume = true;
  std::int64_t lowest_revision_after = std::numeric_limits<std::int64_t>::max();
  auto track = [&](const MappingProgress& p) {
    if (p.revision > 0) lowest_revision_after = std::min(lowest_revision_after, p.revision);
  };
  const MappingReport report = RunMapping(kClip / "video.mp4", out, options, track);
  EXPECT_EQ(report.resumed_from_frame, checkpoint->resume_frame);
  // Map revisions keep growing across the interruption (readers cache by revision).
  EXPECT_GT(lowest_revision_after, first_run_revision);
  EXPECT_GT(report.revision, first_run_revision);
  EXPECT_GT(report.submaps, static_cast<std::int64_t>(checkpoint->next_submap_id));
  EXPECT_EQ(report.disconnected_submaps, 0);
  EXPECT_EQ(fs::last_write_time(SubmapDirectory(out / "submaps", 0) / "submap.bin"), first_written);
  // The resumed run keeps the interrupted run's tiles, so its tile URIs keep that run's id.
  const std::string resumed_uri = TilesetContentUri(out);
  EXPECT_EQ(resumed_uri.substr(resumed_uri.find('?')), "?v=" + checkpoint->run_id);

  // As accurate as the same run without the interruption (the resumed submap restarts where
  // the uninterrupted one would have started it, so the two should agree closely).
  const fs::path full = fs::temp_directory_path() / "glam_resume_test_full";
  fs::remove_all(full);
  RunMapping(kClip / "video.mp4", full, DemoOptions());
  // A run from the start writes new tiles: new URIs, so cached tiles of another run are not reused.
  const std::string fresh_uri = TilesetContentUri(full);
  EXPECT_NE(fresh_uri.substr(fresh_uri.find('?')), "?v=" + checkpoint->run_id);
  const eval::EvaluationResult resumed = eval::EvaluateDirectories(kClip, out, {});
  const eval::EvaluationResult uninterrupted = eval::EvaluateDirectories(kClip, full, {});
  EXPECT_GE(resumed.trajectory.fraction_posed, uninterrupted.trajectory.fraction_posed - 0.01);
  EXPECT_LT(resumed.trajectory.ate_rmse, 1.1 * uninterrupted.trajectory.ate_rmse + 0.02)
      << "resumed: " << eval::Summary(resumed) << "\nuninterrupted: " << eval::Summary(uninterrupted);
  // And accurate in absolute terms: under 1 % of the 100 m flying height.
  EXPECT_LT(resumed.trajectory.ate_rmse, 1.0) << eval::Summary(resumed);
  fs::remove_all(out);
  fs::remove_all(full);
}

TEST(ResumeMapping, WithoutACheckpointResumeStartsFromTheBeginning) {
  const fs::path out = fs::temp_directory_path() / "glam_resume_test_fresh";
  fs::remove_all(out);
  fs::create_directories(out / "submaps" / "999999");  // a stale leftover is cleared
  MappingOptions options = DemoOptions();
  options.resume = true;
  options.source.stride = 3;  // quick: 100 frames
  const MappingReport report = RunMapping(kClip / "video.mp4", out, options);
  EXPECT_EQ(report.resumed_from_frame, -1);
  EXPECT_GE(report.submaps, 1);
  EXPECT_FALSE(fs::exists(out / "submaps" / "999999"));
  fs::remove_all(out);
}

// Frame indices of a photo folder are places in its (capture-time) order, so a checkpoint made
// with the photos in one order must not be resumed with them in another (`--name-order` now, or
// a checkpoint of a version that mapped photos in name order).
TEST(ResumeMapping, APhotoFolderInAnotherOrderStartsFromTheBeginning) {
  const fs::path dir = fs::temp_directory_path() / "glam_resume_test_photos";
  fs::remove_all(dir);
  fs::create_directories(dir / "photos");
  cv::VideoCapture video((kClip / "video.mp4").string(), cv::CAP_FFMPEG);
  ASSERT_TRUE(video.isOpened());
  cv::Mat image;
  int photos = 0;
  for (int i = 0; video.read(image) && photos < 20; ++i) {
    if (i % 6 != 0) continue;
    // A counter that wrapped after the 5th photo: name order is not capture order.
    glam::testing::WritePhoto(dir / "photos" / fmt::format("DJI_{:04}.JPG", (9995 + photos) % 10000), image, nullptr,
                              fmt::format("2026:12:05 10:00:{:02}", 2 * photos));
    ++photos;
  }
  MappingOptions options = DemoOptions();
  options.intrinsics.reset();  // the photos are not downscaled like the video's intrinsics assume
  options.submap.bundle_adjustment.refine_focal = true;
  const MappingReport first = RunMapping(dir / "photos", dir / "out", options);
  EXPECT_EQ(first.photos_reordered_by_time, photos);
  ASSERT_TRUE(fs::exists(dir / "out" / kCheckpointFile));
  EXPECT_EQ(ReadCheckpoint(dir / "out")->photos_reordered_by_time, photos);

  options.resume = true;
  options.source.photos_by_capture_time = false;
  const MappingReport renamed = RunMapping(dir / "photos", dir / "out", options);
  EXPECT_EQ(renamed.photos_reordered_by_time, 0);
  EXPECT_EQ(renamed.resumed_from_frame, -1);  // started again
  // Control: the same order resumes (here at the end of the photos: nothing left to map).
  const MappingReport again = RunMapping(dir / "photos", dir / "out", options);
  EXPECT_GE(again.resumed_from_frame, 0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace glam
