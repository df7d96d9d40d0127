#include "engine/video/frame_source.h"

#include <algorithm>
#include <cctype>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "engine/core/error.h"
#include "engine/core/options.h"
#include "engine/video/image_folder_source.h"
#include "engine/video/stream_source.h"
#include "engine/video/video_file_source.h"

namespace glam {

void FrameSourceOptions::Check() const {
  if (max_image_size != 0) CheckGreaterEqual("FrameSourceOptions.max_image_size", max_image_size, 16);
  CheckGreaterEqual("FrameSourceOptions.stride", stride, 1);
  CheckInRange("FrameSourceOptions.stream_buffer_s", stream_buffer_s, 0.0, 600.0);
  CheckInRange("FrameSourceOptions.stream_buffer_max_mb", stream_buffer_max_mb, 1, 65536);
  CheckInRange("FrameSourceOptions.stream_open_timeout_s", stream_open_timeout_s, 0.01, 86400.0);
  CheckInRange("FrameSourceOptions.stream_stall_timeout_s", stream_stall_timeout_s, 0.01, 86400.0);
  for (const auto& [key, value] : stream_options) {
    if (key.empty()) throw InputError("FrameSourceOptions.stream_options: an option without a name");
  }
}

std::string UrlScheme(const std::string& input) {
  const std::size_t colon = input.find("://");
  std::string scheme = colon == std::string::npos ? std::string() : input.substr(0, colon);
  for (char& c : scheme) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return scheme;
}

bool IsStreamInput(const std::string& input) {
  if (input == "-") return true;
  if (input.rfind("pipe:", 0) == 0) return true;
  const std::string scheme = UrlScheme(input);
  for (const char* known : {"rtsp", "rtsps", "rtmp", "rtmps", "srt", "udp", "rtp", "tcp", "http", "https"}) {
    if (scheme == known) return true;
  }
  return false;
}

cv::Size ProcessingSize(cv::Size original, int max_image_size) {
  const int long_side = std::max(original.width, original.height);
  if (max_image_size <= 0 || long_side <= max_image_size) return original;
  const double scale = static_cast<double>(max_image_size) / long_side;
  return {std::max(1, static_cast<int>(std::lround(original.width * scale))),
          std::max(1, static_cast<int>(std::lround(original.height * scale)))};
}

cv::Mat ToProcessingSize(const cv::Mat& image, cv::Size processing_size) {
  if (image.size() == processing_size) return image;
  cv::Mat out;
  cv::resize(image, out, processing_size, 0, 0, cv::INTER_AREA);
  return out;
}

std::unique_ptr<FrameSource> OpenFrameSource(const std::filesystem::path& path,
                                             const FrameSourceOptions& options) {
  options.Check();
  if (options.allow_streams && IsStreamInput(path.string())) {
    return std::make_unique<StreamSource>(path.string(), options);
  }
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw InputError(fmt::format("input '{}' does not exist", path.string()));
  }
  if (std::filesystem::is_directory(path, ec)) {
    return std::make_unique<ImageFolderSource>(path, options);
  }
  return std::make_unique<VideoFileSource>(path, options);
}

FrameSourceInfo ProbeVideo(const std::filesystem::path& path, const FrameSourceOptions& options) {
  // Opening already decodes the first frame (video) or image (folder). The order of a folder's
  // photos does not change what is probed, so their EXIF times are not read (20,000 files).
  FrameSourceOptions probe = options;
  probe.photos_by_capture_time = false;
  return OpenFrameSource(path, probe)->info();
}

}  // namespace glam
