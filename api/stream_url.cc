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

std::string RedactStreamUrl(const std::string& url) {
  const std::size_t scheme_end = url.find("://");
  if (scheme_end == std::string::npos) return url;
  const std::size_t authority = scheme_end + 3;
  const std::size_t authority_end = url.find_first_of("/?#", authority);
  std::string out = url;
  // user:password@host (an empty user part, udp://@:5004, is FFmpeg's "any address").
  const std::size_t at = url.rfind('@', authority_end);
  if (at != std::string::npos && at > authority) out = url.substr(0, authority) + "***" + url.substr(at);
  // Query parameters that carry secrets (SRT's passphrase, tokens of HTTP and RTMP servers).
  const std::size_t query = out.find('?');
  if (query == std::string::npos) return out;
  std::string redacted = out.substr(0, query + 1);
  std::size_t begin = query + 1;
  while (begin <= out.size()) {
    std::size_t end = out.find_first_of("&#", begin);
    if (end == std::string::npos) end = out.size();
    std::string pair = out.substr(begin, end - begin);
    const std::size_t eq = pair.find('=');
    std::string key = pair.substr(0, eq);
    for (char& c : key) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (eq != std::string::npos) {
      for (const char* secret : {"passphrase", "password", "pass", "pwd", "token", "key", "secret"}) {
        if (key == secret) pair = pair.substr(0, eq + 1) + "***";
      }
    }
    redacted += pair;
    if (end == out.size()) break;
    if (out[end] == '#') {
      redacted += out.substr(end);
      break;
    }
    redacted += '&';
    begin = end + 1;
  }
  return redacted;
}

}  // namespace glam::api
