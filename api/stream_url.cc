#include "api/stream_url.h"

#include <cctype>

#include <fmt/format.h>

#include "api/api_error.h"
#include "engine/video/frame_source.h"

namespace glam::api {

void CheckStreamUrl(const std::string& url) {
  constexpr std::size_t kMaxLength = 2048;
  const char* kAccepted = "rtsp://, rtsps://, rtmp://, rtmps://, srt://, udp://, rtp://, tcp://, http:// or https://";
  if (url.empty() || url.size() > kMaxLength) {
    throw ApiError(400, "bad_request", fmt::format("stream_url must be a URL of 1 to {} characters", kMaxLength));
  }
  for (const char c : url) {
    if (std::iscntrl(static_cast<unsigned char>(c)) || c == ' ') {
      throw ApiError(400, "bad_request", "stream_url must not contain spaces or control characters");
    }
  }
  // IsStreamInput also takes "-" and pipe:N, the CLI's standard input; the server has none.
  if (url == "-" || url.rfind("pipe:", 0) == 0 || !IsStreamInput(url)) {
    throw ApiError(400, "bad_request",
                   fmt::format("stream_url must be an {} URL of a live video stream", kAccepted));
  }
}

}  // namespace glam::api
