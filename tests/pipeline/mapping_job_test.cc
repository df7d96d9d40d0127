// RunMapping's threading contract: cancel returns promptly with Cancelled and joins the
// decoder thread; bad input and bad options are InputErrors; the CLI maps them to exit 2.
#include "engine/pipeline/mapping_job.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace glam {
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("glam_pipeline_test_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A folder of textured noise frames (drifting so that frames differ).
fs::path NoiseFolder(const std::string& name, int frames) {
  const fs::path dir = TempDir(name);
  cv::Mat base(240, 320, CV_8UC3);
  cv::randu(base, 0, 255);
  for (int i = 0; i < frames; ++i) {
    cv::Mat frame = base(cv::Rect(0, 0, 320, 240)).clone();
    cv::Mat shifted;
    cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, i * 2.0, 0, 1, 0);
    cv::warpAffine(frame, shifted, m, frame.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    char file[32];
    std::snprintf(file, sizeof(file), "%04d.png", i);
    cv::imwrite((dir / file).string(), shifted);
  }
  return dir;
}

TEST(MappingJob, CancelBeforeStartThrowsCancelled) {
  const fs::path input = NoiseFolder("cancel_before", 3);
  CancellationToken cancel;
  cancel.Cancel();
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THROW(RunMapping(input, TempDir("cancel_before_out"), MappingOptions{}, {}, cancel), Cancelled);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
}

TEST(MappingJob, CancelDuringRunJoinsAndThrowsCancelled) {
  const fs::path input = NoiseFolder("cancel_during", 60);
  CancellationToken cancel;
  std::int64_t frames_seen = 0;
  auto progress = [&](const MappingProgress& p) {
    frames_seen = p.frames_done;
    if (p.frames_done >= 3) cancel.Cancel();
  };
  MappingOptions options;
  options.queue_capacity = 2;
  EXPECT_THROW(RunMapping(input, TempDir("cancel_during_out"), options, progress, cancel), Cancelled);
  EXPECT_LT(frames_seen, 60);
}

TEST(MappingJob, MissingInputAndBadOptionsAreInputErrors) {
  EXPECT_THROW(RunMapping("/nonexistent/video.mp4", TempDir("missing_out"), MappingOptions{}),
               InputError);
  MappingOptions bad;
  bad.queue_capacity = 0;
  EXPECT_THROW(RunMapping(NoiseFolder("bad_opts", 2), TempDir("bad_opts_out"), bad), InputError);
  MappingOptions wrong_size;
  Intrinsics in;
  in.width = 1920;
  in.height = 1080;
  in.fx = in.fy = 1500;
  in.cx = 960;
  in.cy = 540;
  wrong_size.intrinsics = in;
  EXPECT_THROW(RunMapping(NoiseFolder("wrong_size", 2), TempDir("wrong_size_out"), wrong_size),
               InputError);
}

TEST(MappingJob, IntrinsicsAreRescaledToProcessingSize) {
  FrameSourceInfo info;
  info.original_size = {3840, 2160};
  info.processing_size = {1280, 720};
  info.scale = 1.0 / 3.0;
  MappingOptions options;
  Intrinsics in;
  in.width = 3840;
  in.height = 2160;
  in.fx = 3000;
  in.fy = 3003;
  in.cx = 1919.5;
  in.cy = 1079.5;
  options.intrinsics = in;
  const Intrinsics out = ResolveIntrinsics(options, info);
  EXPECT_NEAR(out.fx, 1000, 1e-9);
  EXPECT_NEAR(out.fy, 1001, 1e-9);
  EXPECT_NEAR(out.cx, 639.5, 1e-9);  // image centre stays the image centre
  EXPECT_NEAR(out.cy, 359.5, 1e-9);
  options.intrinsics.reset();
  options.focal_px = 2400;
  EXPECT_NEAR(ResolveIntrinsics(options, info).fx, 800, 1e-9);
  options.focal_px.reset();
  EXPECT_NEAR(ResolveIntrinsics(options, info).fx, 0.8 * 1280, 1e-9);
}

int RunCli(const std::string& args, std::string* output) {
  const std::string command = std::string(GLAM_BIN) + " " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return -1;
  char buffer[512];
  while (fgets(buffer, sizeof(buffer), pipe) != nullptr) *output += buffer;
  const int status = pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// The automatic detection schedule in frames: 0.2 s of input after the stride, stretched up to
// max_detection_seconds when asked for; a fixed --detect-every, photo folders (1 fps) and the
// default (0 s) stay fixed.
TEST(MappingOptions, DetectionIntervalsFollowTheFrameRate) {
  MappingOptions o;
  EXPECT_EQ(o.EffectiveMaxDetectionInterval(30), 6);  // off by default
  o.max_detection_seconds = 1.0;
  EXPECT_EQ(o.EffectiveDetectionInterval(30), 6);
  EXPECT_EQ(o.EffectiveMaxDetectionInterval(30), 30);
  EXPECT_EQ(o.EffectiveDetectionInterval(15), 3);
  EXPECT_EQ(o.EffectiveMaxDetectionInterval(15), 15);
  EXPECT_EQ(o.EffectiveMaxDetectionInterval(1), 1);  // a photo folder: SIFT on every photo
  o.source.stride = 2;
  EXPECT_EQ(o.EffectiveDetectionInterval(30), 3);
  EXPECT_EQ(o.EffectiveMaxDetectionInterval(30), 15);
  o.source.stride = 1;
  o.max_detection_seconds = 0;
  EXPECT_EQ(o.EffectiveMaxDetectionInterval(30), 6);
  o.max_detection_seconds = 1.0;
  o.detection_interval = 4;
  EXPECT_EQ(o.EffectiveDetectionInterval(30), 4);
  EXPECT_EQ(o.EffectiveMaxDetectionInterval(30), 4);
  o.detection_interval = 0;
  o.max_detection_seconds = -1;
  EXPECT_THROW(o.Check(), InputError);
}

// The paper preset turns every documented deviation with an option back, and nothing else.
TEST(MappingOptions, PaperMethodTurnsTheDeviationsOff) {
  const MappingOptions defaults;
  MappingOptions paper;
  UsePaperMethod(&paper);
  EXPECT_NO_THROW(paper.Check());
  EXPECT_EQ(paper.detection_interval, 1);
  EXPECT_EQ(paper.sift.grid_cols, 0);
  EXPECT_EQ(paper.submap.max_keyframe_parallax_deg, 0.0);
  EXPECT_EQ(paper.submap.min_map_coverage, 0.0);
  EXPECT_EQ(paper.submap.bootstrap_accept_parallax_deg, 0.0);
  EXPECT_FALSE(paper.submap.bundle_adjustment.share_focal);
  EXPECT_EQ(paper.submap.focal_prior_growth, 0.0);
  EXPECT_EQ(paper.submap.rebuild_focal_change, 0.0);
  EXPECT_EQ(paper.submap.completion_ba_max_frames, 0);
  EXPECT_FALSE(paper.submap.extend_short_final_submap);
  EXPECT_FALSE(paper.alignment.use_shared_frames);
  EXPECT_EQ(paper.alignment.local_window, 0);
  EXPECT_EQ(paper.alignment.max_demotable_submaps, 0);
  EXPECT_FALSE(paper.submap.duplicate_check_in_view);
  EXPECT_EQ(paper.submap.local_ba_keyframes, 0);
  // Epipolar matching for triangulation comes with a calibration, and the preset takes it
  // back when applied after it (as `glam map --intrinsics --paper` does).
  EXPECT_FALSE(defaults.submap.epipolar_triangulation_matching);
  MappingOptions calibrated;
  Intrinsics in;
  in.width = 640;
  in.height = 360;
  in.fx = in.fy = 500;
  in.cx = 319.5;
  in.cy = 179.5;
  UseCalibration(&calibrated, in);
  EXPECT_TRUE(calibrated.submap.epipolar_triangulation_matching);
  UsePaperMethod(&calibrated);
  EXPECT_FALSE(calibrated.submap.epipolar_triangulation_matching);
  // The defaults do deviate (else the preset would be a no-op), and the paper's own
  // parameters are untouched.
  EXPECT_NE(defaults.detection_interval, 1);
  EXPECT_GT(defaults.sift.grid_cols, 0);
  EXPECT_GT(defaults.submap.completion_ba_max_frames, 0);
  EXPECT_GT(defaults.submap.min_map_coverage, 0.0);
  EXPECT_GT(defaults.alignment.max_demotable_submaps, 0);
  EXPECT_GT(defaults.submap.local_ba_keyframes, 0);
  EXPECT_EQ(paper.submap.tau_resection, defaults.submap.tau_resection);
  EXPECT_EQ(paper.submap.tau_stereo, defaults.submap.tau_stereo);
  EXPECT_EQ(paper.submap.keyframes_per_submap, defaults.submap.keyframes_per_submap);
  EXPECT_EQ(paper.submap.overlap_fraction, defaults.submap.overlap_fraction);
  EXPECT_EQ(paper.sift.max_features, defaults.sift.max_features);
  EXPECT_EQ(paper.sift.root_sift, defaults.sift.root_sift);
}

TEST(MapCli, PaperCannotBeCombinedWithTheOptionsItSets) {
  const fs::path input = NoiseFolder("cli_paper", 2);
  std::string output;
  EXPECT_EQ(RunCli("map " + input.string() + " --out " + TempDir("cli_paper_a").string() +
                       " --paper --detect-every 6", &output), 2);
  EXPECT_NE(output.find("--paper"), std::string::npos) << output;
  EXPECT_NE(output.find("--detect-every"), std::string::npos) << output;
  output.clear();
  EXPECT_EQ(RunCli("map " + input.string() + " --out " + TempDir("cli_paper_b").string() + " --paper",
                   &output), 0) << output;
}

TEST(MapCli, MissingInputExitsTwoWithMessage) {
  std::string output;
  EXPECT_EQ(RunCli("map /nonexistent/clip.mp4 --out " + TempDir("cli_missing").string(), &output), 2);
  EXPECT_NE(output.find("/nonexistent/clip.mp4"), std::string::npos) << output;
}

TEST(MapCli, UnwritableOutputAndBadOptionsExitTwo) {
  const fs::path input = NoiseFolder("cli_out", 2);
  const fs::path file = TempDir("cli_file") / "plain_file";
  { std::FILE* f = std::fopen(file.c_str(), "w"); std::fclose(f); }
  std::string output;
  EXPECT_EQ(RunCli("map " + input.string() + " --out " + (file / "sub").string(), &output), 2);
  EXPECT_NE(output.find("output directory"), std::string::npos) << output;
  output.clear();
  EXPECT_EQ(RunCli("map " + input.string() + " --out " + TempDir("cli_stride").string() + " --stride 0", &output), 2);
  EXPECT_NE(output.find("stride"), std::string::npos) << output;
}

// --log-level is taken before or after the command (README: every command takes it).
TEST(MapCli, LogLevelWorksAfterTheCommandToo) {
  const fs::path input = NoiseFolder("cli_log", 2);
  std::string before, after, bad;
  RunCli("--log-level debug map " + input.string() + " --out " + TempDir("cli_log_a").string(), &before);
  RunCli("map " + input.string() + " --out " + TempDir("cli_log_b").string() + " --log-level debug", &after);
  EXPECT_NE(before.find(" debug "), std::string::npos) << before;
  EXPECT_NE(after.find(" debug "), std::string::npos) << after;
  EXPECT_EQ(RunCli("map " + input.string() + " --out " + TempDir("cli_log_c").string() + " --log-level loud", &bad), 2);
  EXPECT_NE(bad.find("loud"), std::string::npos) << bad;
}

}  // namespace
}  // namespace glam
