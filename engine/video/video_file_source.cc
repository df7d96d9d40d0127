#include "engine/video/video_file_source.h"

#include <algorithm>
#include <cmath>

#include "engine/core/error.h"
#include "engine/core/logging.h"

namespace glam {
namespace {

// Forward seeks shorter than this are done by grabbing (exact, cheap for short gaps);
// longer ones ask FFmpeg to seek.
constexpr int64_t kMaxGrabSeek = 48;

// Container frame counts are estimates (duration x fps); allow this much slack before calling
// a video truncated.
bool EndedWellBefore(int64_t decoded, int64_t announced) {
  if (announced <= 0) return false;
  const int64_t slack = std::max<int64_t>(2, announced / 100);
  return decoded + slack < announced;
}

}  // namespace

VideoFileSource::VideoFileSource(const std::filesystem::path& path,
                                 const FrameSourceOptions& options)
    : path_(path), options_(options) {
  options_.Check();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw InputError(fmt::format("video '{}' does not exist", path.string()));
  }
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw InputError(fmt::format("video '{}' is not a regular file", path.string()));
  }
  if (std::filesystem::file_size(path, ec) == 0) {
    throw InputError(fmt::format("video '{}' is empty (0 bytes)", path.string()));
  }
  decoder_ = std::make_unique<VideoDecoder>(path);  // throws InputError for non-videos
  if (!decoder_->Grab()) {
    throw InputError(fmt::format("video '{}' contains no decodable frames", path.string()));
  }
  position_ = 1;

  info_.fps = decoder_->fps();
  if (!(info_.fps > 0.0) || !std::isfinite(info_.fps) || info_.fps > 1000.0) {
    GLAM_LOG_WARN("video '{}' reports no usable frame rate ({}); assuming 30 fps",
                  path.string(), info_.fps);
    info_.fps = 30.0;
  }
  info_.frame_count = decoder_->announced_frame_count();
  info_.original_size = decoder_->display_size();
  info_.processing_size = ProcessingSize(info_.original_size, options_.max_image_size);
  info_.scale = static_cast<double>(info_.processing_size.width) / info_.original_size.width;
  // Converted now so that a pixel format we cannot convert fails the probe, not the job.
  decoder_->Retrieve(info_.processing_size, &first_bgr_);
  GLAM_LOG_DEBUG("opened video '{}': {}x{} @ {:.3f} fps, ~{} frames, processing {}x{}",
                 path.string(), info_.original_size.width, info_.original_size.height, info_.fps,
                 info_.frame_count, info_.processing_size.width, info_.processing_size.height);
}

void VideoFileSource::MarkEnd() {
  done_ = true;
  if (EndedWellBefore(position_, info_.frame_count)) {
    ended_early_ = true;
    GLAM_LOG_WARN(
        "video '{}' ended after {} decodable frames, but the container announced {}: the file "
        "is truncated or corrupt; continuing with the frames read",
        path_.string(), position_, info_.frame_count);
  }
}

std::optional<Frame> VideoFileSource::Next() {
  if (done_) return std::nullopt;
  const bool first = next_index_ == 0 && !first_bgr_.empty();  // converted at open
  if (!first) {
    // Frames before the one asked for are decoded but not converted.
    while (position_ <= next_index_) {
      if (!decoder_->Grab()) {
        MarkEnd();
        return std::nullopt;
      }
      ++position_;
    }
  }

  Frame frame;
  frame.index = next_index_;
  frame.timestamp_s = static_cast<double>(next_index_) / info_.fps;
  frame.original_size = decoder_->display_size();
  if (first) {
    frame.bgr = first_bgr_;
  } else {
    decoder_->Retrieve(info_.processing_size, &frame.bgr);
  }
  first_bgr_.release();
  next_index_ += options_.stride;
  ++delivered_;
  return frame;
}

void VideoFileSource::SeekTo(int64_t index) {
  if (index < 0 || (info_.frame_count > 0 && index > info_.frame_count)) {
    throw InputError(fmt::format("cannot seek to frame {} of '{}' ({} frames)", index,
                                 path_.string(), info_.frame_count));
  }
  next_index_ = index;
  done_ = info_.frame_count > 0 && index == info_.frame_count;  // at the end: nothing left
  if (done_) return;
  if (!first_bgr_.empty() && index == 0) return;
  if (index >= position_ && index - position_ <= kMaxGrabSeek) return;  // grab forward
  first_bgr_.release();
  if (!decoder_->Seek(index)) {  // the stream ends before `index`
    position_ = decoder_->index() + 1;
    MarkEnd();
    return;
  }
  position_ = index;
}

}  // namespace glam
