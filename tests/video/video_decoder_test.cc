// The video decoder (engine/video/video_decoder.h) against known answers: the index each test
// frame carries in its pixels, and OpenCV's FFmpeg backend as an independent decoder of the same
// files (it also scales and rotates; GLAM used it before).
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "engine/core/error.h"
#include "engine/video/frame_source.h"
#include "engine/video/video_decoder.h"
#include "tests/video/test_media.h"

namespace glam {
namespace {

using testing::DecodeIndex;
using testing::HaveFfmpeg;
using testing::WriteWithFfmpeg;

class VideoDecoderTest : public testing::TempDirTest {};

// Frames of smooth colour texture (blurred noise) with a different pattern per frame, so a
// scaling or colour error shows everywhere in the picture, not only at a few edges.
void WriteTexturedAvi(const std::filesystem::path& path, cv::Size size, int frames) {
  cv::VideoWriter writer(path.string(), cv::CAP_OPENCV_MJPEG,
                         cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 30.0, size);
  ASSERT_TRUE(writer.isOpened());
  cv::RNG rng(11);
  for (int i = 0; i < frames; ++i) {
    cv::Mat noise(size, CV_8UC3);
    rng.fill(noise, cv::RNG::UNIFORM, cv::Scalar::all(0), cv::Scalar::all(255));
    cv::GaussianBlur(noise, noise, cv::Size(0, 0), 3.0);
    cv::normalize(noise, noise, 0, 255, cv::NORM_MINMAX);
    writer.write(noise);
  }
}

// Every frame as OpenCV's FFmpeg backend decodes it, resized with INTER_AREA to `size`.
std::vector<cv::Mat> ReadWithOpenCv(const std::filesystem::path& path, cv::Size size) {
  cv::VideoCapture capture(path.string(), cv::CAP_FFMPEG);
  std::vector<cv::Mat> frames;
  cv::Mat bgr;
  while (capture.read(bgr) && !bgr.empty()) frames.push_back(ToProcessingSize(bgr, size).clone());
  return frames;
}

double MeanGreyDifference(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat grey_a, grey_b, diff;
  cv::cvtColor(a, grey_a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(b, grey_b, cv::COLOR_BGR2GRAY);
  cv::absdiff(grey_a, grey_b, diff);
  return cv::mean(diff)[0];
}

TEST_F(VideoDecoderTest, FramesMatchOpenCvsDecoderAtFullAndReducedSize) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg binary not available";
  const auto avi = dir_ / "textured.avi";
  WriteTexturedAvi(avi, {640, 360}, 12);
  const auto mp4 = dir_ / "textured.mp4";
  ASSERT_TRUE(testing::TranscodeWithFfmpeg(avi, mp4,
                                           "-c:v libx264 -preset ultrafast -qp 4 -pix_fmt yuv420p"));

  for (const auto& path : {avi, mp4}) {   // full-range Motion-JPEG and limited-range H.264
    for (const int max_size : {0, 320, 200}) {
      SCOPED_TRACE(path.filename().string() + " max_image_size " + std::to_string(max_size));
      FrameSourceOptions options;
      options.max_image_size = max_size;
      auto source = OpenFrameSource(path, options);
      const cv::Size size = source->info().processing_size;
      const auto reference = ReadWithOpenCv(path, size);
      ASSERT_EQ(reference.size(), 12u);
      std::size_t i = 0;
      while (auto frame = source->Next()) {
        ASSERT_LT(i, reference.size());
        ASSERT_EQ(frame->bgr.size(), size);
        ASSERT_EQ(frame->bgr.type(), CV_8UC3);
        // The same picture: well under the difference a one-pixel shift makes.
        cv::Mat shifted;
        const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 1, 0, 1, 0);
        cv::warpAffine(reference[i], shifted, shift, size, cv::INTER_NEAREST, cv::BORDER_REPLICATE);
        const double difference = MeanGreyDifference(frame->bgr, reference[i]);
        EXPECT_LT(difference, 1.5) << "frame " << i;
        EXPECT_LT(difference, 0.5 * MeanGreyDifference(shifted, reference[i])) << "frame " << i;
        ++i;
      }
      EXPECT_EQ(i, reference.size());
    }
  }
}

// Phones and some drones store the picture sideways and a display rotation beside it; the
// frames must come out upright (as players and OpenCV show them), with the size swapped.
TEST_F(VideoDecoderTest, DisplayRotationIsApplied) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg binary not available";
  const auto plain = dir_ / "plain.mp4";
  ASSERT_TRUE(testing::WriteMp4(plain, {320, 180}, 5, 30.0));
  const cv::Mat stored = OpenFrameSource(plain)->Next()->bgr;

  const std::vector<std::pair<int, int>> rotations = {
      {90, cv::ROTATE_90_CLOCKWISE}, {180, cv::ROTATE_180}, {270, cv::ROTATE_90_COUNTERCLOCKWISE}};
  for (const auto& [degrees, code] : rotations) {
    SCOPED_TRACE("rotate=" + std::to_string(degrees));
    const auto rotated = dir_ / ("rotated" + std::to_string(degrees) + ".mp4");
    ASSERT_TRUE(testing::TranscodeWithFfmpeg(
        plain, rotated, "-c copy -metadata:s:v:0 rotate=" + std::to_string(degrees)));

    auto source = OpenFrameSource(rotated);
    const cv::Size upright = degrees == 180 ? cv::Size(320, 180) : cv::Size(180, 320);
    EXPECT_EQ(source->info().original_size, upright);
    EXPECT_EQ(source->info().processing_size, upright);
    const auto frame = source->Next();
    ASSERT_TRUE(frame.has_value());
    EXPECT_EQ(frame->original_size, upright);
    cv::Mat expected;
    cv::rotate(stored, expected, code);
    ASSERT_EQ(frame->bgr.size(), expected.size());
    EXPECT_LT(MeanGreyDifference(frame->bgr, expected), 0.5);
    const auto opencv = ReadWithOpenCv(rotated, upright);
    ASSERT_FALSE(opencv.empty());
    EXPECT_LT(MeanGreyDifference(frame->bgr, opencv.front()), 1.5);
  }
}

// Reads every frame, then seeks far forward, backward and to the ends; each frame must be the
// one its index names. `frames` frames of 320x180.
void ExpectExactFramesAndSeeks(const std::filesystem::path& path, int frames) {
  auto source = OpenFrameSource(path);
  EXPECT_EQ(source->info().frame_count, frames);
  int count = 0;
  while (auto frame = source->Next()) {
    EXPECT_EQ(DecodeIndex(frame->bgr, frames), frame->index);
    ++count;
  }
  EXPECT_EQ(count, frames);
  for (const int target : {frames - 15, frames - 14, 2, 0, frames - 1, frames / 2, 1}) {
    source->SeekTo(target);
    const auto frame = source->Next();
    ASSERT_TRUE(frame.has_value()) << "seek to " << target;
    EXPECT_EQ(frame->index, target);
    EXPECT_EQ(DecodeIndex(frame->bgr, frames), target) << "seek to " << target;
  }
}

// B-frames reorder frames between decoding and display; seeking must still land on the frame
// asked for. The file also carries an audio track, which the decoder must skip.
TEST_F(VideoDecoderTest, H264WithBFramesAndAudioSeeksExactly) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg binary not available";
  const auto path = dir_ / "bframes.mp4";
  ASSERT_TRUE(WriteWithFfmpeg(path, {320, 180}, 90, 30.0,
                              "-f lavfi -i sine=frequency=440:duration=3 -map 0:v -map 1:a "
                              "-c:v libx264 -preset medium -bf 3 -g 24 -qp 10 -pix_fmt yuv420p "
                              "-c:a aac -shortest"));
  ExpectExactFramesAndSeeks(path, 90);
}

// Most drone footage today: H.265, 10 bits per sample.
TEST_F(VideoDecoderTest, TenBitHevcSeeksExactly) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg binary not available";
  const auto path = dir_ / "hevc10.mp4";
  if (!WriteWithFfmpeg(path, {320, 180}, 90, 30.0,
                       "-c:v libx265 -preset ultrafast -x265-params "
                       "log-level=error:bframes=3:keyint=24 -pix_fmt yuv420p10le -tag:v hvc1")) {
    GTEST_SKIP() << "ffmpeg without libx265";
  }
  ExpectExactFramesAndSeeks(path, 90);
}

// Other containers and codecs users upload: VP9 in Matroska (timestamps in milliseconds, not
// frames), MPEG-4 Part 2 with B-frames in AVI, 10-bit 4:2:2 ProRes in QuickTime, H.264 in an
// MPEG transport stream.
TEST_F(VideoDecoderTest, OtherContainersAndCodecsSeekExactly) {
  if (!HaveFfmpeg()) GTEST_SKIP() << "ffmpeg binary not available";
  const std::vector<std::pair<std::string, std::string>> formats = {
      {"vp9.mkv", "-c:v libvpx-vp9 -crf 10 -b:v 0 -deadline realtime -cpu-used 8 -g 24"},
      {"mpeg4.avi", "-c:v mpeg4 -q:v 2 -bf 2 -g 24"},
      {"prores.mov", "-c:v prores_ks -profile:v 2 -pix_fmt yuv422p10le"},
      // MPEG-TS (live recordings): no frame count, 90 kHz clock starting at ~1.4 s.
      {"h264.ts", "-c:v libx264 -preset ultrafast -bf 2 -g 24 -qp 10 -pix_fmt yuv420p"},
  };
  for (const auto& [name, encode] : formats) {
    SCOPED_TRACE(name);
    const auto path = dir_ / name;
    if (!WriteWithFfmpeg(path, {320, 180}, 90, 30.0, encode)) {
      ADD_FAILURE() << "ffmpeg could not write " << name;  // all are in Debian's ffmpeg
      continue;
    }
    ExpectExactFramesAndSeeks(path, 90);
  }
}

// A damaged frame in the middle costs that frame, not the rest of the video.
TEST_F(VideoDecoderTest, DamageInTheMiddleIsSkipped) {
  const auto path = dir_ / "damaged.avi";
  testing::WriteAvi(path, {320, 240}, 40, 25.0);
  const auto size = std::filesystem::file_size(path);
  {
    std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(static_cast<std::streamoff>(size / 2));
    std::mt19937 rng(3);
    for (int i = 0; i < 3000; ++i) file.put(static_cast<char>(rng() & 0xff));
  }
  auto source = OpenFrameSource(path);
  int count = 0, last_index = -1;
  while (auto frame = source->Next()) {
    ++count;
    const int index = DecodeIndex(frame->bgr, 40);
    if (index >= 0) last_index = index;
  }
  EXPECT_GE(count, 36);
  EXPECT_EQ(last_index, 39);  // the frames after the damage were decoded
}

TEST_F(VideoDecoderTest, ReportsStreamFacts) {
  const auto path = dir_ / "clip.avi";
  testing::WriteAvi(path, {160, 120}, 7, 12.0);
  VideoDecoder decoder(path);
  EXPECT_DOUBLE_EQ(decoder.fps(), 12.0);
  EXPECT_EQ(decoder.announced_frame_count(), 7);
  EXPECT_EQ(decoder.display_size(), cv::Size());
  ASSERT_TRUE(decoder.Grab());
  EXPECT_EQ(decoder.index(), 0);
  EXPECT_EQ(decoder.display_size(), cv::Size(160, 120));
  cv::Mat bgr;
  decoder.Retrieve({80, 60}, &bgr);
  EXPECT_EQ(bgr.size(), cv::Size(80, 60));
  EXPECT_EQ(DecodeIndex(bgr, 10), 0);
  ASSERT_TRUE(decoder.Seek(5));
  ASSERT_TRUE(decoder.Grab());
  EXPECT_EQ(decoder.index(), 5);
  decoder.Retrieve({160, 120}, &bgr);
  EXPECT_EQ(DecodeIndex(bgr, 10), 5);
  ASSERT_TRUE(decoder.Grab());
  EXPECT_FALSE(decoder.Grab());  // 7 frames: 0 .. 6
  EXPECT_FALSE(decoder.Seek(9));

  VideoDecoderOptions options;
  options.threads = -1;
  EXPECT_THROW(VideoDecoder(path, options), InputError);
  std::ofstream(dir_ / "text.mp4") << "not a video at all\n";
  EXPECT_THROW(VideoDecoder(dir_ / "text.mp4"), InputError);
}

}  // namespace
}  // namespace glam
