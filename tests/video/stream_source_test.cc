// StreamSource (live streams): every frame of a stream arrives in order with its stream index
// (pipes, GLAM listening on TCP and RTMP, GLAM pulling RTMP and SRT from a listening sender);
// when the reader is too slow, whole frames are dropped (the oldest buffered ones) and the
// frames that remain still carry the right index; a silent stream, a sender that never
// connects and the user's end request each end the input within their time; and nothing but
// the program's own choice (allow_streams) makes FFmpeg open a URL. The frames carry their
// index as grey levels (test_media.h), so the test knows which frame it was handed.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "engine/core/error.h"
#include "engine/video/frame_source.h"
#include "engine/video/stream_source.h"
#include "tests/support/free_port.h"
#include "tests/support/pipe_feeder.h"
#include "tests/video/test_media.h"

namespace glam {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using testing::DecodeIndex;
using testing::FreePort;
using testing::PipeFeeder;

constexpr int kFrames = 120;
constexpr double kFps = 25.0;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

class StreamSourceTest : public testing::TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    signal(SIGPIPE, SIG_IGN);  // a closed reader must end a writer, not the test
    if (!testing::HaveFfmpeg()) GTEST_SKIP() << "ffmpeg binary not available";
    clip_ = dir_ / "clip.ts";
    // H.264 in MPEG-TS, the usual container of a live feed.
    ASSERT_TRUE(testing::WriteWithFfmpeg(clip_, {320, 240}, kFrames, kFps,
                                         "-c:v libx264 -preset ultrafast -pix_fmt yuv420p -g 10 -f mpegts"));
  }

  FrameSourceOptions Options() const {
    FrameSourceOptions options;
    options.allow_streams = true;
    options.stream_open_timeout_s = 10;
    return options;
  }

  // An ffmpeg sender of the clip (`ffmpeg -nostdin -v error <input_args> -i clip <output_args>`)
  // in a child process. retry: the sender connects to GLAM's listener, so it tries again until
  // that is up (at most 100 times).
  pid_t StartSender(const std::string& input_args, const std::string& output_args, bool retry) const {
    const std::string ffmpeg = "ffmpeg -nostdin -v error " + input_args + " -i '" + clip_.string() + "' " + output_args;
    const std::string command =
        retry ? "for i in $(seq 100); do " + ffmpeg + " && exit 0; sleep 0.1; done; exit 1" : "exec " + ffmpeg;
    const pid_t sender = fork();
    if (sender == 0) {
      execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
    return sender;
  }

  static void ExpectSenderSucceeded(pid_t sender) {
    int status = 0;
    waitpid(sender, &status, 0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }

  // Reads `source` to its end; every frame must be the next one of the clip, by its index and
  // by its content. *count: the frames read.
  static void ReadInOrder(FrameSource& source, int* count) {
    *count = 0;
    while (auto frame = source.Next()) {
      ASSERT_EQ(frame->index, *count);
      EXPECT_EQ(DecodeIndex(frame->bgr, kFrames), *count);
      ++*count;
    }
    EXPECT_EQ(source.frames_dropped(), 0);
  }

  fs::path clip_;
};

TEST(StreamInput, RecognisesStreamUrlsAndNotPaths) {
  for (const char* url : {"rtsp://192.168.1.1:8554/live", "RTSP://CAM/live", "rtmp://host/app/key",
                          "srt://0.0.0.0:9000?mode=listener", "udp://@:5000", "rtp://239.0.0.1:5004",
                          "tcp://0.0.0.0:5000?listen=1", "http://host/feed.ts", "https://host/feed.m3u8",
                          "-", "pipe:0", "pipe:7"}) {
    EXPECT_TRUE(IsStreamInput(url)) << url;
  }
  for (const char* path : {"clip.mp4", "/data/rtsp/clip.mp4", "./rtsp:/x", "file:///tmp/x.mp4",
                           "concat:a.ts|b.ts", "C:/video.mp4", "ftp://host/x.mp4", ""}) {
    EXPECT_FALSE(IsStreamInput(path)) << path;
  }
  using Drop = FrameSourceOptions::StreamDrop;
  EXPECT_TRUE(StreamDropsFrames("rtsp://cam/live", Drop::kAuto));
  EXPECT_TRUE(StreamDropsFrames("udp://@:5000", Drop::kAuto));
  EXPECT_TRUE(StreamDropsFrames("SRT://host:9000", Drop::kAuto));
  EXPECT_FALSE(StreamDropsFrames("tcp://host:5000", Drop::kAuto));
  EXPECT_FALSE(StreamDropsFrames("-", Drop::kAuto));
  EXPECT_TRUE(StreamDropsFrames("-", Drop::kDrop));
  EXPECT_FALSE(StreamDropsFrames("rtsp://cam/live", Drop::kWait));
  EXPECT_EQ(StreamUrl("-"), "pipe:0");
  EXPECT_EQ(StreamUrl("udp://@:5000"), "udp://@:5000");
}

TEST(StreamInput, UrlsAreOnlyOpenedWhenAllowed) {
  // The server passes paths it stored itself and never allows streams: a URL is then just a
  // file that does not exist, and FFmpeg is never asked to connect anywhere.
  const std::string url = "tcp://127.0.0.1:" + std::to_string(FreePort());
  try {
    OpenFrameSource(url, FrameSourceOptions{});
    ADD_FAILURE() << "opened " << url;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  FrameSourceOptions allowed;
  allowed.allow_streams = true;
  allowed.stream_open_timeout_s = 5;
  try {
    OpenFrameSource(url, allowed);  // nobody listens: connection refused
    ADD_FAILURE() << "opened " << url;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open stream"), std::string::npos) << e.what();
  }
  allowed.stream_buffer_s = -1;
  EXPECT_THROW(allowed.Check(), InputError);
}

TEST_F(StreamSourceTest, PipeDeliversEveryFrameInOrder) {
  PipeFeeder feeder(clip_);
  auto source = OpenFrameSource(feeder.url(), Options());
  auto* stream = dynamic_cast<StreamSource*>(source.get());
  ASSERT_NE(stream, nullptr);
  EXPECT_FALSE(stream->drops_frames());  // a pipe waits for its reader
  const FrameSourceInfo& info = source->info();
  EXPECT_EQ(info.frame_count, -1);
  EXPECT_NEAR(info.fps, kFps, 1e-6);
  EXPECT_EQ(info.processing_size, cv::Size(320, 240));
  EXPECT_NO_THROW(source->SeekTo(0));  // where it is

  int expected = 0;
  while (auto frame = source->Next()) {
    ASSERT_EQ(frame->index, expected);
    EXPECT_DOUBLE_EQ(frame->timestamp_s, expected / kFps);
    EXPECT_EQ(DecodeIndex(frame->bgr, kFrames), expected);
    ++expected;
  }
  EXPECT_EQ(expected, kFrames);
  EXPECT_EQ(source->frames_delivered(), kFrames);
  EXPECT_EQ(source->frames_dropped(), 0);
  EXPECT_FALSE(source->ended_early());
  EXPECT_THROW(source->SeekTo(0), InputError);  // a stream does not go back
}

TEST_F(StreamSourceTest, SeekingBeforeTheFirstFrameNumbersTheStreamFromThere) {
  // A resumed run continues its frame numbers: the stream's first frame becomes frame 1000.
  PipeFeeder feeder(clip_);
  FrameSourceOptions options = Options();
  options.stride = 2;
  auto source = OpenFrameSource(feeder.url(), options);
  source->SeekTo(1000);
  int64_t expected = 1000;
  while (auto frame = source->Next()) {
    ASSERT_EQ(frame->index, expected);
    EXPECT_DOUBLE_EQ(frame->timestamp_s, expected / kFps);
    EXPECT_EQ(DecodeIndex(frame->bgr, kFrames), expected - 1000);
    expected += 2;
    if (expected == 1010) {
      EXPECT_THROW(source->SeekTo(2000), InputError);  // not once frames were delivered
      EXPECT_THROW(source->SeekTo(1004), InputError);
    }
  }
  EXPECT_EQ(expected, 1000 + kFrames);
}

TEST_F(StreamSourceTest, FramesLostInTransitLeaveAGapInTheNumbers) {
  // Frames 30-39 never arrive (the timestamps of the others are kept): the frames after the
  // gap keep their numbers, so their time is right.
  const fs::path lossy = dir_ / "lossy.ts";
  ASSERT_TRUE(testing::TranscodeWithFfmpeg(
      clip_, lossy,
      "-vf \"select='not(between(n\\,30\\,39))'\" -fps_mode passthrough -c:v libx264 -preset ultrafast "
      "-pix_fmt yuv420p -g 10 -f mpegts"));
  PipeFeeder feeder(lossy);
  auto source = OpenFrameSource(feeder.url(), Options());
  std::vector<int64_t> indices;
  while (auto frame = source->Next()) {
    EXPECT_EQ(DecodeIndex(frame->bgr, kFrames), frame->index);
    EXPECT_DOUBLE_EQ(frame->timestamp_s, frame->index / kFps);
    indices.push_back(frame->index);
  }
  ASSERT_EQ(indices.size(), static_cast<std::size_t>(kFrames - 10));
  EXPECT_EQ(indices[29], 29);
  EXPECT_EQ(indices[30], 40);
  EXPECT_EQ(indices.back(), kFrames - 1);
}

TEST_F(StreamSourceTest, ASenderThatRestartsItsClockIsNumberedOn) {
  // The clip sent twice, its timestamps starting again at 0 the second time (a restarted
  // encoder): the second pass is numbered after the first, not on top of it.
  const fs::path twice = dir_ / "twice.ts";
  {
    std::ofstream out(twice, std::ios::binary);
    for (int pass = 0; pass < 2; ++pass) {
      std::ifstream in(clip_, std::ios::binary);
      out << in.rdbuf();
    }
  }
  PipeFeeder feeder(twice);
  auto source = OpenFrameSource(feeder.url(), Options());
  int64_t expected = 0;
  while (auto frame = source->Next()) {
    ASSERT_EQ(frame->index, expected);
    EXPECT_EQ(DecodeIndex(frame->bgr, kFrames), expected % kFrames);
    ++expected;
  }
  EXPECT_EQ(expected, 2 * kFrames);
}

TEST_F(StreamSourceTest, StrideKeepsTheStreamIndices) {
  PipeFeeder feeder(clip_);
  FrameSourceOptions options = Options();
  options.stride = 3;
  auto source = OpenFrameSource(feeder.url(), options);
  int expected = 0;
  while (auto frame = source->Next()) {
    ASSERT_EQ(frame->index, expected);
    EXPECT_EQ(DecodeIndex(frame->bgr, kFrames), expected);
    expected += 3;
  }
  EXPECT_EQ(expected, kFrames);
}

TEST_F(StreamSourceTest, DropsTheOldestFramesWhenTheReaderFallsBehind) {
  PipeFeeder feeder(clip_);
  FrameSourceOptions options = Options();
  options.stream_drop = FrameSourceOptions::StreamDrop::kDrop;
  options.stream_buffer_s = 0.12;  // 3 frames at 25 fps
  auto source = OpenFrameSource(feeder.url(), options);
  auto* stream = dynamic_cast<StreamSource*>(source.get());
  ASSERT_NE(stream, nullptr);
  EXPECT_TRUE(stream->drops_frames());
  EXPECT_EQ(stream->buffer_capacity(), 3u);

  std::vector<int64_t> indices;
  while (auto frame = source->Next()) {
    // Each frame is the one its index says, whatever was dropped around it.
    EXPECT_EQ(DecodeIndex(frame->bgr, kFrames), frame->index);
    if (!indices.empty()) {
      EXPECT_GT(frame->index, indices.back());
    }
    indices.push_back(frame->index);
    std::this_thread::sleep_for(std::chrono::milliseconds(25));  // mapping, slower than decoding
  }
  ASSERT_FALSE(indices.empty());
  EXPECT_GT(source->frames_dropped(), 0);
  EXPECT_EQ(static_cast<int64_t>(indices.size()) + source->frames_dropped(), kFrames);
  EXPECT_EQ(indices.front(), 0);
  EXPECT_EQ(indices.back(), kFrames - 1);  // the newest frames are kept
}

TEST_F(StreamSourceTest, TheBufferHoldsSecondsOfStreamUpToItsMemoryBound) {
  {
    PipeFeeder feeder(clip_);
    FrameSourceOptions options = Options();
    auto source = OpenFrameSource(feeder.url(), options);
    EXPECT_EQ(dynamic_cast<StreamSource&>(*source).buffer_capacity(), 50u);  // 2 s at 25 fps
  }
  PipeFeeder feeder(clip_);
  FrameSourceOptions options = Options();
  options.stream_buffer_s = 10;
  options.stream_buffer_max_mb = 1;  // 4 frames of 320x240 BGR (230,400 bytes each)
  auto source = OpenFrameSource(feeder.url(), options);
  EXPECT_EQ(dynamic_cast<StreamSource&>(*source).buffer_capacity(), 4u);
}

TEST_F(StreamSourceTest, ASilentSenderEndsTheStreamAfterTheStallTimeout) {
  // Half the stream, then the sender stays connected but sends nothing.
  PipeFeeder feeder(clip_, static_cast<std::size_t>(fs::file_size(clip_) / 2), /*hold_open=*/true);
  FrameSourceOptions options = Options();
  options.stream_stall_timeout_s = 0.5;
  auto source = OpenFrameSource(feeder.url(), options);
  const auto start = Clock::now();
  int frames = 0;
  while (auto frame = source->Next()) {
    EXPECT_EQ(DecodeIndex(frame->bgr, kFrames), frame->index);
    ++frames;
  }
  EXPECT_LT(SecondsSince(start), 5.0);
  EXPECT_GT(frames, 10);
  EXPECT_LT(frames, kFrames);
  feeder.Release();
}

TEST_F(StreamSourceTest, TheEndRequestEndsTheStreamAndKeepsTheBufferedFrames) {
  PipeFeeder feeder(clip_, SIZE_MAX, /*hold_open=*/true);  // never ends by itself
  FrameSourceOptions options = Options();
  options.stream_stall_timeout_s = 60;  // only the request may end it
  auto source = OpenFrameSource(feeder.url(), options);
  int frames = 0;
  Clock::time_point requested;
  while (auto frame = source->Next()) {
    EXPECT_EQ(DecodeIndex(frame->bgr, kFrames), frame->index);
    if (++frames == 10) {
      options.end_stream.Cancel();  // the token is shared with the source's copy
      requested = Clock::now();
    }
  }
  EXPECT_LT(SecondsSince(requested), 5.0);
  EXPECT_GE(frames, 10);
  EXPECT_EQ(source->frames_dropped(), 0);
}

TEST_F(StreamSourceTest, FramesDeliveredAroundAnEndRequestAreIntact) {
  // Ending a stream cuts a read off mid-packet; what the source delivers must still be whole
  // frames, pixel for pixel those of the file. Ended at several points of the stream.
  std::vector<cv::Mat> truth;
  {
    FrameSourceOptions file_options;
    auto file = OpenFrameSource(clip_, file_options);
    while (auto frame = file->Next()) truth.push_back(frame->bgr.clone());
  }
  ASSERT_EQ(truth.size(), static_cast<std::size_t>(kFrames));
  for (const int end_after : {5, 23, 41, 77}) {
    PipeFeeder feeder(clip_, SIZE_MAX, /*hold_open=*/true);
    FrameSourceOptions options = Options();
    options.stream_buffer_s = 0.2;  // 5 frames: the reader is mid-stream when the request comes
    auto source = OpenFrameSource(feeder.url(), options);
    int frames = 0;
    while (auto frame = source->Next()) {
      ASSERT_LT(frame->index, kFrames);
      EXPECT_EQ(cv::norm(frame->bgr, truth[static_cast<std::size_t>(frame->index)], cv::NORM_INF), 0.0)
          << "frame " << frame->index << " of a stream ended after " << end_after;
      if (++frames == end_after) options.end_stream.Cancel();
    }
    // The request is prompt: the buffer's frames and the one being decoded, no more.
    EXPECT_LE(frames, end_after + 5 + 1) << "ended after " << end_after;
  }
}

TEST_F(StreamSourceTest, GivesUpWhenNoSenderConnects) {
  FrameSourceOptions options = Options();
  options.stream_open_timeout_s = 0.5;
  const auto start = Clock::now();
  // Credentials in the URL never reach a message (or a log line).
  const std::string url = "tcp://viewer:hunter2@127.0.0.1:" + std::to_string(FreePort()) + "?listen=1";
  try {
    OpenFrameSource(url, options);
    ADD_FAILURE() << "opened " << url;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open stream 'tcp://***@127.0.0.1:"), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find("hunter2"), std::string::npos) << e.what();
  }
  EXPECT_LT(SecondsSince(start), 5.0);
}

TEST_F(StreamSourceTest, ReadsWhatASenderPushesOverTcp) {
  // GLAM listens; ffmpeg connects (retrying until the listener is up) and sends the clip.
  const int port = FreePort();
  const pid_t sender = StartSender("", "-c copy -f mpegts tcp://127.0.0.1:" + std::to_string(port), true);
  ASSERT_GE(sender, 0);
  int read = 0;
  {
    auto source = OpenFrameSource("tcp://127.0.0.1:" + std::to_string(port) + "?listen=1", Options());
    ReadInOrder(*source, &read);
  }
  ExpectSenderSucceeded(sender);
  EXPECT_EQ(read, kFrames);
}

// A stream GLAM pulls from a server (the usual RTMP and SRT setup: a media server or the
// ground station listens, GLAM connects as a client): an ffmpeg sender listens and sends the
// clip in real time (-re); GLAM retries until the listener is up. Every frame arrives in order
// with its index (up to `lost_at_end` of the last ones may be lost in the sender's close).
class PulledStreamTest : public StreamSourceTest {
 protected:
  // `sender_args`: ffmpeg output options and URL (listening). `url`: what GLAM opens.
  void ReadsEveryFrame(const std::string& sender_args, const std::string& url, int lost_at_end = 0) {
    const pid_t sender = StartSender("-re", sender_args, false);
    ASSERT_GE(sender, 0);
    std::unique_ptr<FrameSource> source;
    FrameSourceOptions options = Options();
    options.stream_drop = FrameSourceOptions::StreamDrop::kWait;  // every frame must arrive
    for (int attempt = 0; attempt < 100 && !source; ++attempt) {
      try {
        source = OpenFrameSource(url, options);
      } catch (const InputError&) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the listener is not up yet
      }
    }
    ASSERT_NE(source, nullptr) << "could not open " << url;
    EXPECT_NEAR(source->info().fps, kFps, 1e-6);
    EXPECT_EQ(source->info().processing_size, cv::Size(320, 240));
    int read = 0;
    ReadInOrder(*source, &read);
    EXPECT_LE(read, kFrames);
    EXPECT_GE(read, kFrames - lost_at_end);
    source.reset();
    ExpectSenderSucceeded(sender);
  }
};

TEST_F(PulledStreamTest, ReadsAnRtmpServersStream) {
  const std::string url = "rtmp://127.0.0.1:" + std::to_string(FreePort()) + "/live/drone";
  ReadsEveryFrame("-c copy -f flv -listen 1 " + url, url);
}

TEST_F(PulledStreamTest, ReadsAnSrtListenersStream) {
  const std::string url = "srt://127.0.0.1:" + std::to_string(FreePort());
  // libsrt in live mode discards what it has not sent when the sender closes: ffmpeg's own
  // receiver gets 117-118 of the 120 frames too. A drone's feed does not end that way.
  ReadsEveryFrame("-c copy -f mpegts '" + url + "?mode=listener'", url, 5);
}

TEST_F(StreamSourceTest, ReadsAnRtmpPushToItsOwnListener) {
  // GLAM as the RTMP server (a drone app's "custom RTMP" live stream pushes to it): the
  // demuxer's listen=1; ffmpeg pushes, retrying until the listener is up.
  const int port = FreePort();
  const std::string url = "rtmp://127.0.0.1:" + std::to_string(port) + "/live/drone";
  const pid_t sender = StartSender("-re", "-c copy -f flv " + url, true);
  ASSERT_GE(sender, 0);
  FrameSourceOptions options = Options();
  options.stream_options.emplace_back("listen", "1");
  options.stream_drop = FrameSourceOptions::StreamDrop::kWait;  // every frame must arrive
  int read = 0;
  {
    auto source = OpenFrameSource(url, options);
    ReadInOrder(*source, &read);
  }
  ExpectSenderSucceeded(sender);
  EXPECT_EQ(read, kFrames);
}

}  // namespace
}  // namespace glam
