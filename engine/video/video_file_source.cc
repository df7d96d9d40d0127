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
  if (!capture_.open(path.string(), cv::CAP_FFMPEG)) {
    throw InputError(fmt::format(
        "cannot open '{}' as a video: not a video file, or a codec FFmpeg cannot decode",
        path.string()));
  }
  if (!capture_.read(first_frame_) || first_frame_.empty()) {
    throw InputError(fmt::format("video '{}' contains no decodable frames", path.string()));
  }
  position_ = 1;

  info_.fps = capture_.get(cv::CAP_PROP_FPS);
  if (!(info_.fps > 0.0) || !std::isfinite(info_.fps) || info_.fps > 1000.0) {
    GLAM_LOG_WARN("video '{}' reports no usable frame rate ({}); assuming 30 fps",
                  path.string(), info_.fps);
    info_.fps = 30.0;
  }
  const double count = capture_.get(cv::CAP_PROP_FRAME_COUNT);
  info_.frame_count = (count >= 1.0 && std::isfinite(count)) ? static_cast<int64_t>(count) : -1;
  info_.original_size = first_frame_.size();
  info_.processing_size = ProcessingSize(info_.original_size, options_.max_image_size);
  info_.scale = static_cast<double>(info_.processing_size.width) / info_.original_size.width;
  GLAM_LOG_DEBUG("opened video '{}': {}x{} @ {:.3f} fps, ~{} frames, processing {}x{}",
                 path.string(), info_.original_size.width, info_.original_size.height, info_.fps,
                 info_.frame_count, info_.processing_size.width, info_.processing_size.height);
}

bool VideoFileSource::DecodeNext(cv::Mat* bgr) {
  const bool ok = bgr != nullptr ? capture_.read(*bgr) && !bgr->empty() : capture_.grab();
  if (ok) ++position_;
  return ok;
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
  cv::Mat bgr;
  if (next_index_ == 0 && position_ == 1 && !first_frame_.empty()) {
    bgr = first_frame_;  // decoded at open
  } else {
    while (position_ < next_index_) {
      if (!DecodeNext(nullptr)) {
        MarkEnd();
        return std::nullopt;
      }
    }
    if (!DecodeNext(&bgr)) {
      MarkEnd();
      return std::nullopt;
    }
  }
  first_frame_.release();

  Frame frame;
  frame.index = next_index_;
  frame.timestamp_s = static_cast<double>(next_index_) / info_.fps;
  frame.original_size = bgr.size();
  frame.bgr = ToProcessingSize(bgr, info_.processing_size);
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
  const bool first_pending = (position_ == 1 && !first_frame_.empty());
  if (first_pending && index == 0) return;
  if (index >= position_ && index - position_ <= kMaxGrabSeek) return;  // grab forward
  first_frame_.release();
  if (!capture_.set(cv::CAP_PROP_POS_FRAMES, static_cast<double>(index))) {
    throw EnvironmentError(
        fmt::format("decoder cannot seek to frame {} of '{}'", index, path_.string()));
  }
  position_ = static_cast<int64_t>(std::llround(capture_.get(cv::CAP_PROP_POS_FRAMES)));
  if (position_ > index) {
    throw EnvironmentError(fmt::format("decoder overshot seeking to frame {} of '{}' (at {})",
                                       index, path_.string(), position_));
  }
}

}  // namespace glam
