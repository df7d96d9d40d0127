// H.264 (yuv420p) MP4 writer for the synthetic clips. Frames are piped as raw BGR into the
// `ffmpeg` binary (Debian package ffmpeg) with libx264 at a fixed CRF, which gives us control
// over quality: compression artefacts would otherwise destroy the fine texture the tracker
// needs. Without an ffmpeg binary on PATH it falls back to cv::VideoWriter (FFmpeg backend,
// fourcc 'avc1'), whose bitrate we cannot set.
#pragma once

#include <cstdio>
#include <filesystem>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

namespace glam::synth {

class VideoWriter {
 public:
  // Throws EnvironmentError if no encoder can be started.
  VideoWriter(const std::filesystem::path& path, int width, int height, double fps, int crf);
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  // bgr: CV_8UC3 of the size given at construction. Throws EnvironmentError on failure.
  void Write(const cv::Mat& bgr);
  // Flushes and waits for the encoder; throws EnvironmentError if it failed.
  void Close();

 private:
  std::filesystem::path path_;
  int width_;
  int height_;
  std::FILE* pipe_ = nullptr;
  cv::VideoWriter fallback_;
};

}  // namespace glam::synth
