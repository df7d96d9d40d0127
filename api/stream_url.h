// Live-stream URLs that clients send for stream jobs (JobService::CreateStreamJob): which
// ones the server accepts, and how they are shown. The server opens these URLs itself, so the
// check is strict: network protocols FFmpeg reads live video over, nothing that reaches the
// server's own files or standard input (file:, pipe:, "-", concat:, ...).
#pragma once

#include <string>

namespace glam::api {

// Throws ApiError 400 "bad_request" (naming the accepted schemes) unless `url` is an rtsp,
// rtsps, rtmp, rtmps, srt, udp, rtp, tcp, http or https URL of at most 2048 characters
// without spaces or control characters.
void CheckStreamUrl(const std::string& url);

// RedactStreamUrl (engine/video/stream_source.h) shows such a URL without its credentials.

}  // namespace glam::api
