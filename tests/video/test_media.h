// Tiny media files written by the tests themselves. Every frame carries its index as the grey
// level of a large block, which survives lossy compression, so tests can tell which frame a
// source delivered (after stride, seek, downscale).
#pragma once

#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <unistd.h>

namespace glam::testing {

// Index i is written as two grey blocks: low "digit" (i % 16) left, high digit (i / 16) right,
// 14 grey levels apart, so indices up to 255 are unambiguous.
inline int DigitLevel(int digit) { return 20 + 14 * digit; }

inline cv::Mat MakeFrame(cv::Size size, int index) {
  cv::Mat frame(size, CV_8UC3, cv::Scalar(40, 90, 160));
  const int w = size.width / 4, h = size.height / 2;
  cv::rectangle(frame, cv::Rect(size.width / 8, size.height / 4, w, h),
                cv::Scalar::all(DigitLevel(index % 16)), cv::FILLED);
  cv::rectangle(frame, cv::Rect(size.width * 5 / 8, size.height / 4, w, h),
                cv::Scalar::all(DigitLevel(index / 16)), cv::FILLED);
  return frame;
}

// Index encoded by MakeFrame, or -1 when a block matches no level or the index > max_index.
inline int DecodeIndex(const cv::Mat& frame, int max_index) {
  auto digit = [&](int x0) {
    const cv::Rect centre(x0 + frame.cols / 16, frame.rows * 3 / 8, frame.cols / 8, frame.rows / 4);
    const double level = cv::mean(frame(centre))[1];
    for (int d = 0; d < 16; ++d) {
      if (std::abs(level - DigitLevel(d)) < 4.0) return d;
    }
    return -100000;
  };
  const int index = digit(frame.cols / 8) + 16 * digit(frame.cols * 5 / 8);
  return index >= 0 && index <= max_index ? index : -1;
}

// Motion-JPEG AVI through OpenCV's built-in writer (always available).
inline void WriteAvi(const std::filesystem::path& path, cv::Size size, int frames, double fps) {
  cv::VideoWriter writer(path.string(), cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                         fps, size);
  ASSERT_TRUE(writer.isOpened()) << path;
  for (int i = 0; i < frames; ++i) writer.write(MakeFrame(size, i));
}

inline bool HaveFfmpeg() { return std::system("ffmpeg -version > /dev/null 2>&1") == 0; }

// Runs the ffmpeg binary on `input`, writing `output` with the output options `encode`
// (codec, pixel format, GOP, metadata; extra inputs may come first). True on success.
inline bool TranscodeWithFfmpeg(const std::filesystem::path& input,
                                const std::filesystem::path& output, const std::string& encode) {
  const std::string cmd = "ffmpeg -nostdin -v error -y -i '" + input.string() + "' " + encode +
                          " '" + output.string() + "'";
  return std::system(cmd.c_str()) == 0;
}

// A video encoded by the ffmpeg binary from an AVI written with WriteAvi.
inline bool WriteWithFfmpeg(const std::filesystem::path& path, cv::Size size, int frames,
                            double fps, const std::string& encode) {
  const auto avi = path.parent_path() / (path.stem().string() + "_src.avi");
  WriteAvi(avi, size, frames, fps);
  return TranscodeWithFfmpeg(avi, path, encode);
}

// H.264 MP4 (moov atom first, as streaming-friendly encoders write it).
inline bool WriteMp4(const std::filesystem::path& path, cv::Size size, int frames, double fps) {
  return WriteWithFfmpeg(path, size, frames, fps,
                         "-c:v libx264 -preset ultrafast -qp 10 -pix_fmt yuv420p -g 10 "
                         "-movflags +faststart");
}

class TempDirTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("glam_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" +
            std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::filesystem::path dir_;
};

}  // namespace glam::testing
