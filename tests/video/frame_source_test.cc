#include <fstream>
#include <random>

#include <gtest/gtest.h>

#include "engine/core/error.h"
#include "engine/video/frame_source.h"
#include "engine/video/video_file_source.h"
#include "tests/video/test_media.h"

namespace glam {
namespace {

using testing::DecodeIndex;
using testing::WriteAvi;

class VideoFileSourceTest : public testing::TempDirTest {};

TEST_F(VideoFileSourceTest, DeliversEveryFrameWithInfoAndTimestamps) {
  const auto path = dir_ / "clip.avi";
  WriteAvi(path, {320, 240}, 20, 25.0);
  auto source = OpenFrameSource(path);
  const FrameSourceInfo& info = source->info();
  EXPECT_DOUBLE_EQ(info.fps, 25.0);
  EXPECT_EQ(info.frame_count, 20);
  EXPECT_EQ(info.original_size, cv::Size(320, 240));
  EXPECT_EQ(info.processing_size, cv::Size(320, 240));
  EXPECT_DOUBLE_EQ(info.scale, 1.0);

  int expected = 0;
  while (auto frame = source->Next()) {
    EXPECT_EQ(frame->index, expected);
    EXPECT_DOUBLE_EQ(frame->timestamp_s, expected / 25.0);
    EXPECT_EQ(frame->bgr.type(), CV_8UC3);
    EXPECT_EQ(frame->bgr.size(), cv::Size(320, 240));
    EXPECT_EQ(DecodeIndex(frame->bgr, 40), expected);
    ++expected;
  }
  EXPECT_EQ(expected, 20);
  EXPECT_EQ(source->frames_delivered(), 20);
  EXPECT_FALSE(source->ended_early());
  EXPECT_FALSE(source->Next().has_value());  // stays at the end
}

TEST_F(VideoFileSourceTest, DownscalesLargeFramesToMaxImageSize) {
  const auto path = dir_ / "big.avi";
  WriteAvi(path, {1280, 720}, 3, 30.0);
  FrameSourceOptions options;
  options.max_image_size = 640;
  auto source = OpenFrameSource(path, options);
  EXPECT_EQ(source->info().original_size, cv::Size(1280, 720));
  EXPECT_EQ(source->info().processing_size, cv::Size(640, 360));
  EXPECT_DOUBLE_EQ(source->info().scale, 0.5);
  auto frame = source->Next();
  ASSERT_TRUE(frame.has_value());
  EXPECT_EQ(frame->bgr.size(), cv::Size(640, 360));
  EXPECT_EQ(frame->original_size, cv::Size(1280, 720));
  EXPECT_EQ(DecodeIndex(frame->bgr, 10), 0);

  options.max_image_size = 0;  // disabled
  EXPECT_EQ(OpenFrameSource(path, options)->Next()->bgr.size(), cv::Size(1280, 720));
}

TEST(ProcessingSize, KeepsAspectAndLongSide) {
  EXPECT_EQ(ProcessingSize({3840, 2160}, 1280), cv::Size(1280, 720));
  EXPECT_EQ(ProcessingSize({2160, 3840}, 1280), cv::Size(720, 1280));  // portrait
  EXPECT_EQ(ProcessingSize({1000, 500}, 1280), cv::Size(1000, 500));   // never upscales
  EXPECT_EQ(ProcessingSize({4000, 3000}, 0), cv::Size(4000, 3000));
}

TEST_F(VideoFileSourceTest, StrideDeliversEveryNthFrame) {
  const auto path = dir_ / "clip.avi";
  WriteAvi(path, {160, 120}, 11, 10.0);
  FrameSourceOptions options;
  options.stride = 3;
  auto source = OpenFrameSource(path, options);
  std::vector<int64_t> indices;
  while (auto frame = source->Next()) {
    EXPECT_EQ(DecodeIndex(frame->bgr, 20), frame->index);
    EXPECT_DOUBLE_EQ(frame->timestamp_s, frame->index / 10.0);
    indices.push_back(frame->index);
  }
  EXPECT_EQ(indices, (std::vector<int64_t>{0, 3, 6, 9}));
  EXPECT_FALSE(source->ended_early());
}

TEST_F(VideoFileSourceTest, SeekForwardFarAndBackward) {
  const auto path = dir_ / "long.avi";
  WriteAvi(path, {160, 120}, 90, 30.0);
  auto source = OpenFrameSource(path);
  source->SeekTo(5);  // short forward: grabbed
  EXPECT_EQ(source->Next()->index, 5);
  source->SeekTo(75);  // long forward: decoder seek
  auto frame = source->Next();
  ASSERT_TRUE(frame.has_value());
  EXPECT_EQ(frame->index, 75);
  EXPECT_EQ(DecodeIndex(frame->bgr, 100), 75);
  EXPECT_EQ(DecodeIndex(source->Next()->bgr, 100), 76);
  source->SeekTo(2);  // backward
  frame = source->Next();
  ASSERT_TRUE(frame.has_value());
  EXPECT_EQ(DecodeIndex(frame->bgr, 100), 2);
  source->SeekTo(0);
  EXPECT_EQ(DecodeIndex(source->Next()->bgr, 100), 0);
  // The end itself is a valid position (a resumed run whose last submap ended the input).
  source->SeekTo(90);
  EXPECT_FALSE(source->Next().has_value());
  source->SeekTo(88);
  EXPECT_EQ(DecodeIndex(source->Next()->bgr, 100), 88);
  EXPECT_THROW(source->SeekTo(91), InputError);
  EXPECT_THROW(source->SeekTo(-1), InputError);
}

TEST_F(VideoFileSourceTest, DecodesH264Mp4AndSeeks) {
  if (!testing::HaveFfmpeg()) GTEST_SKIP() << "ffmpeg binary not available";
  const auto path = dir_ / "clip.mp4";
  ASSERT_TRUE(testing::WriteMp4(path, {320, 180}, 60, 30.0));
  auto source = OpenFrameSource(path);
  EXPECT_NEAR(source->info().fps, 30.0, 1e-6);
  EXPECT_EQ(source->info().frame_count, 60);
  int count = 0;
  while (auto frame = source->Next()) {
    EXPECT_EQ(DecodeIndex(frame->bgr, 100), frame->index);
    ++count;
  }
  EXPECT_EQ(count, 60);
  source->SeekTo(57);
  EXPECT_EQ(DecodeIndex(source->Next()->bgr, 100), 57);
  source->SeekTo(3);
  EXPECT_EQ(DecodeIndex(source->Next()->bgr, 100), 3);
}

TEST_F(VideoFileSourceTest, RejectsMissingEmptyAndCorruptFiles) {
  try {
    OpenFrameSource(dir_ / "nope.mp4");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("does not exist"), std::string::npos) << e.what();
  }
  std::ofstream(dir_ / "empty.mp4").close();
  EXPECT_THROW(OpenFrameSource(dir_ / "empty.mp4"), InputError);

  std::mt19937 rng(7);
  std::ofstream garbage(dir_ / "garbage.mp4", std::ios::binary);
  for (int i = 0; i < 200000; ++i) garbage.put(static_cast<char>(rng() & 0xff));
  garbage.close();
  EXPECT_THROW(OpenFrameSource(dir_ / "garbage.mp4"), InputError);
  EXPECT_THROW(ProbeVideo(dir_ / "garbage.mp4"), InputError);
}

// Cuts a file to `fraction` of its size.
void Truncate(const std::filesystem::path& path, double fraction) {
  const auto size = std::filesystem::file_size(path);
  std::filesystem::resize_file(path, static_cast<uintmax_t>(size * fraction));
}

// A truncated file must either be rejected with InputError or deliver fewer frames than
// announced, flagged as ended early; never crash or hang.
void ExpectTruncatedHandled(const std::filesystem::path& path, int full_count) {
  std::unique_ptr<FrameSource> source;
  try {
    source = OpenFrameSource(path);
  } catch (const InputError&) {
    return;
  }
  int count = 0;
  while (auto frame = source->Next()) {
    ++count;
    ASSERT_LE(count, full_count);
  }
  EXPECT_LT(count, full_count);
  EXPECT_GT(count, 0);
  EXPECT_TRUE(source->ended_early());
}

TEST_F(VideoFileSourceTest, TruncatedAviEndsEarlyWithoutCrash) {
  const auto path = dir_ / "cut.avi";
  WriteAvi(path, {320, 240}, 40, 25.0);
  Truncate(path, 0.5);
  auto source = OpenFrameSource(path);  // AVI is readable without its index
  EXPECT_EQ(source->info().frame_count, 40);
  ExpectTruncatedHandled(path, 40);
}

TEST_F(VideoFileSourceTest, TruncatedMp4EndsEarlyOrIsRejected) {
  if (!testing::HaveFfmpeg()) GTEST_SKIP() << "ffmpeg binary not available";
  const auto path = dir_ / "cut.mp4";
  ASSERT_TRUE(testing::WriteMp4(path, {320, 180}, 60, 30.0));
  Truncate(path, 0.5);
  ExpectTruncatedHandled(path, 60);
}

TEST_F(VideoFileSourceTest, ProbeReportsInfo) {
  const auto path = dir_ / "clip.avi";
  WriteAvi(path, {640, 480}, 5, 12.0);
  FrameSourceOptions options;
  options.max_image_size = 320;
  const FrameSourceInfo info = ProbeVideo(path, options);
  EXPECT_EQ(info.frame_count, 5);
  EXPECT_DOUBLE_EQ(info.fps, 12.0);
  EXPECT_EQ(info.processing_size, cv::Size(320, 240));
}

TEST(FrameSourceOptions, CheckRejectsNonsense) {
  FrameSourceOptions options;
  EXPECT_NO_THROW(options.Check());
  options.stride = 0;
  EXPECT_THROW(options.Check(), InputError);
  options = {};
  options.max_image_size = -5;
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace glam
