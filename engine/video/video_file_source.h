// Video files (MP4/MOV/MKV/AVI, H.264/H.265/...) through FFmpeg's libraries (VideoDecoder).
// Decoding is sequential; skipped frames (stride, short forward seeks) are only decoded, not
// converted, and the frames delivered are converted straight to the processing size.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>

#include "engine/video/frame_source.h"
#include "engine/video/video_decoder.h"

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
  void MarkEnd();

  std::filesystem::path path_;
  FrameSourceOptions options_;
  std::unique_ptr<VideoDecoder> decoder_;
  FrameSourceInfo info_;
  // Frame 0, decoded and converted at open, until it is delivered or a seek moves away from
  // it (empty afterwards: the decoder's current frame is then another one).
  cv::Mat first_bgr_;
  int64_t position_ = 0;        // index of the frame the decoder produces next
  int64_t next_index_ = 0;      // index Next() delivers next
  int64_t delivered_ = 0;
  bool done_ = false;
  bool ended_early_ = false;
};

}  // namespace glam
