// Video files through OpenCV's FFmpeg backend (MP4/MOV/MKV/AVI, H.264/H.265/...).
// Decoding is sequential; skipped frames (stride, short forward seeks) are only grabbed, not
// converted to BGR, which is most of the saving. FFmpeg's own decode threads can be tuned with
// the environment variable OPENCV_FFMPEG_CAPTURE_OPTIONS="threads;N" (OpenCV 4.6 has no
// property for it; we do not set it ourselves because setenv is not thread-safe).
#pragma once

#include <filesystem>
#include <optional>

#include <opencv2/videoio.hpp>

#include "engine/video/frame_source.h"

namespace glam {

class VideoFileSource : public FrameSource {
 public:
  // Opens the file and decodes the first frame so that an unusable file fails here, not later.
  // Throws InputError (missing file, not a video, no decodable frame).
  VideoFileSource(const std::filesystem::path& path, const FrameSourceOptions& options);

  std::optional<Frame> Next() override;
  const FrameSourceInfo& info() const override { return info_; }
  void SeekTo(int64_t index) override;
  int64_t frames_delivered() const override { return delivered_; }
  bool ended_early() const override { return ended_early_; }

 private:
  bool DecodeNext(cv::Mat* bgr);  // decodes frame `position_`, advances position_
  void MarkEnd();

  std::filesystem::path path_;
  FrameSourceOptions options_;
  cv::VideoCapture capture_;
  FrameSourceInfo info_;
  cv::Mat first_frame_;        // decoded at open; served if the first request is frame 0
  int64_t position_ = 0;       // index of the frame the decoder produces next
  int64_t next_index_ = 0;     // index Next() delivers next
  int64_t delivered_ = 0;
  bool done_ = false;
  bool ended_early_ = false;
};

}  // namespace glam
