// A live stream through the whole pipeline (engine/video/stream_source.h): the lawnmower
// fixture's video, remuxed to MPEG-TS as a live feed would arrive, is fed through a pipe. It
// must map as the file does (every frame decoded and posed, ATE within the file run's bounds;
// measured: 0.069 m as a file), report itself as a stream, and when the sender never ends, the
// user's end request (glam map: the first Ctrl-C) must still give the finished map of what
// arrived. Ground truth: the fixture's trajectory (`glam eval`).
#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <sstream>
#include <thread>
#include <vector>

#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "engine/core/intrinsics_io.h"
#include "engine/export/tum_trajectory.h"
#include "engine/map/submap_io.h"
#include "engine/pipeline/resume_checkpoint.h"
#include "engine/pipeline/mapping_job.h"
#include "engine/pipeline/mapping_options.h"
#include "tests/support/pipe_feeder.h"
#include "tests/support/temp_dir.h"
#include "tests/video/test_media.h"
#include "tools/eval/evaluation.h"

namespace glam {
namespace {

namespace fs = std::filesystem;

const fs::path kClip = fs::path(GLAM_TEST_FIXTURES_DIR) / "lawnmower_small";
constexpr int kClipFrames = 300;

class StreamMapping : public ::testing::Test {
 protected:
  void SetUp() override {
    signal(SIGPIPE, SIG_IGN);
    dir_ = testing::FreshTempDir("stream_mapping");
    stream_ = dir_ / "feed.ts";
    ASSERT_TRUE(testing::TranscodeWithFfmpeg(kClip / "video.mp4", stream_, "-c copy -f mpegts"));
    UseCalibration(&options_, ReadIntrinsicsJson(kClip / "intrinsics.json"));
    options_.source.allow_streams = true;
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
  fs::path stream_;
  MappingOptions options_;
};

TEST_F(StreamMapping, ALiveStreamMapsLikeItsFile) {
  testing::PipeFeeder feeder(stream_);
  const fs::path out = dir_ / "out";
  const MappingReport report = RunMapping(feeder.url(), out, options_);
  const eval::EvaluationResult result = eval::EvaluateDirectories(kClip, out, {});
  std::cout << "stream: " << eval::Summary(result) << "\n";
  EXPECT_TRUE(report.input_is_stream);
  EXPECT_EQ(report.frames_total, -1);  // a stream announces no length
  EXPECT_EQ(report.frames_decoded, kClipFrames);
  EXPECT_EQ(report.frames_dropped, 0);  // a pipe waits for the mapper
  EXPECT_GE(report.frames_posed, kClipFrames - 3);
  EXPECT_LT(result.trajectory.ate_rmse, 0.1);
  EXPECT_TRUE(fs::exists(out / "tileset.json"));
}

TEST_F(StreamMapping, TheEndRequestFinishesTheMapOfWhatArrived) {
  // The sender stays connected after its last byte: only the request can end this stream.
  testing::PipeFeeder feeder(stream_, SIZE_MAX, /*hold_open=*/true);
  options_.source.stream_stall_timeout_s = 600;
  const CancellationToken end = options_.source.end_stream;
  const auto progress = [&end](const MappingProgress& p) {
    if (p.frames_done >= 200) end.Cancel();
  };
  const fs::path out = dir_ / "out";
  const MappingReport report = RunMapping(feeder.url(), out, options_, progress);
  const eval::EvaluationResult result = eval::EvaluateDirectories(kClip, out, {});
  std::cout << "ended at frame " << report.frames_decoded << ": " << eval::Summary(result) << "\n";
  EXPECT_GE(report.frames_decoded, 200);
  EXPECT_LE(report.frames_decoded, kClipFrames);
  EXPECT_GE(report.frames_posed, report.frames_decoded - 3);
  EXPECT_EQ(result.trajectory.matched, report.frames_posed);
  EXPECT_LT(result.trajectory.ate_rmse, 0.15);
  EXPECT_TRUE(fs::exists(out / "report.json"));
}

TEST_F(StreamMapping, AResumedStreamKeepsItsSubmapsAndNumbersNewFramesAfterThem) {
  // A run on a stream is interrupted after its first submaps (a server restart); the resumed
  // run cannot go back in the stream, so it maps what arrives now (here the flight again from
  // its start: the same ground) with frame numbers after the mapped ones, and its submaps are
  // linked to the earlier ones by retrieval.
  options_.submap.keyframes_per_submap = 8;
  const fs::path out = dir_ / "out";
  {
    testing::PipeFeeder feeder(stream_);
    CancellationToken cancel;
    const auto progress = [&cancel](const MappingProgress& p) {
      if (p.submaps_completed >= 1) cancel.Cancel();
    };
    EXPECT_THROW(RunMapping(feeder.url(), out, options_, progress, cancel), Cancelled);
  }
  const std::optional<ResumeCheckpoint> checkpoint = ReadCheckpoint(out);
  ASSERT_TRUE(checkpoint.has_value());
  ASSERT_GE(checkpoint->next_submap_id, 1u);
  const std::int64_t mapped_until = ReadSubmap(out / "submaps", checkpoint->next_submap_id - 1).last_frame;

  testing::PipeFeeder feeder(stream_);
  options_.resume = true;
  const MappingReport report = RunMapping(feeder.url(), out, options_);
  std::cout << "resumed at frame " << report.resumed_from_frame << " after frame " << mapped_until << ": "
            << report.submaps << " submaps, " << report.disconnected_submaps << " disconnected, "
            << report.frames_posed << " frames posed\n";
  EXPECT_EQ(report.resumed_from_frame, mapped_until + 1);
  EXPECT_GT(report.submaps, static_cast<std::int64_t>(checkpoint->next_submap_id));
  EXPECT_EQ(report.disconnected_submaps, 0);
  // Both runs' frames are in the trajectory, each frame number once.
  const std::vector<TimedPose> poses = ReadTumTrajectory(out / "trajectory.tum");
  std::int64_t before = 0, after = 0;
  for (const TimedPose& pose : poses) {
    const auto frame = static_cast<std::int64_t>(std::llround(pose.timestamp * 30.0));
    (frame <= mapped_until ? before : after) += 1;
  }
  EXPECT_GE(before, mapped_until * 9 / 10);
  EXPECT_GE(after, kClipFrames * 9 / 10);
}

TEST_F(StreamMapping, CancelWhileASilentStreamIsAwaitedReturnsPromptly) {
  // A third of the stream, then the sender stays connected and silent (its stall timeout is
  // far away): a cancel must not wait for the next frame.
  testing::PipeFeeder feeder(stream_, static_cast<std::size_t>(fs::file_size(stream_) / 3), /*hold_open=*/true);
  options_.source.stream_stall_timeout_s = 600;
  CancellationToken cancel;
  std::atomic<std::int64_t> done{0};
  std::chrono::steady_clock::time_point cancelled_at;
  std::thread canceller([&] {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (done.load() < 30 && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    std::this_thread::sleep_for(std::chrono::seconds(2));  // mapping catches up, then waits
    cancelled_at = std::chrono::steady_clock::now();
    cancel.Cancel();
  });
  const auto progress = [&done](const MappingProgress& p) { done.store(p.frames_done); };
  EXPECT_THROW(RunMapping(feeder.url(), dir_ / "out", options_, progress, cancel), Cancelled);
  const auto returned_at = std::chrono::steady_clock::now();
  canceller.join();
  EXPECT_GE(done.load(), 30);
  EXPECT_LT(std::chrono::duration<double>(returned_at - cancelled_at).count(), 3.0);
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST_F(StreamMapping, CtrlCEndsAStreamOnStandardInputAndTheCliWritesTheMap) {
  // `glam map - < feed` with a sender that never closes: the first SIGINT ends the input,
  // and glam map exits 0 with the map written.
  testing::PipeFeeder feeder(stream_, SIZE_MAX, /*hold_open=*/true);
  const fs::path out = dir_ / "cli_out";
  const fs::path log = dir_ / "cli.log";
  std::vector<std::string> args = {GLAM_BIN, "map", "-", "--out", out.string(), "--intrinsics",
                                   (kClip / "intrinsics.json").string()};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    dup2(feeder.source_fd(), STDIN_FILENO);
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(fd, STDOUT_FILENO);
    dup2(fd, STDERR_FILENO);
    execv(argv[0], argv.data());
    _exit(127);
  }
  // Once the stream is open and mapping has started, the user presses Ctrl-C.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (ReadText(log).find("mapping: ") == std::string::npos && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  kill(pid, SIGINT);
  int status = 0;
  pid_t done = 0;
  while ((done = waitpid(pid, &status, WNOHANG)) == 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (done == 0) {
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
    FAIL() << "glam map did not end after Ctrl-C\n" << ReadText(log);
  }
  const std::string output = ReadText(log);
  ASSERT_TRUE(WIFEXITED(status)) << output;
  EXPECT_EQ(WEXITSTATUS(status), 0) << output;
  EXPECT_NE(output.find("ending the stream"), std::string::npos) << output;
  const nlohmann::json report = nlohmann::json::parse(ReadText(out / "report.json"));
  EXPECT_TRUE(report["input_is_stream"].get<bool>());
  EXPECT_GT(report["frames_posed"].get<int>(), 0);
  EXPECT_TRUE(fs::exists(out / "trajectory.tum"));
}

}  // namespace
}  // namespace glam
