// Helpers shared by the server tests: temporary directories, a tiny real video, and a minimal
// Server-Sent Events client on top of httplib::Client. Include after any Eigen header: httplib.h
// pulls in <resolv.h>, whose macros break Eigen when it is parsed afterwards.
#pragma once

#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include <httplib.h>

#include "tests/support/temp_dir.h"  // FreshTempDir

namespace glam::testing {


// A 64x48 MJPG AVI with `frames` noise frames, written with OpenCV.
std::filesystem::path MakeTinyVideo(const std::filesystem::path& dir, int frames = 8);

std::string ReadFile(const std::filesystem::path& path);

struct SseEvent {
  std::int64_t id = -1;
  std::string type;
  nlohmann::json data;
};

struct SseResult {
  int status = 0;
  std::vector<SseEvent> events;
  bool ended_by_server = false;  // the stream ended without `stop` returning true
};

// GETs an SSE stream and parses events until `stop(event)` returns true, the server ends
// the stream, or `timeout` passes.
SseResult ReadSse(httplib::Client& client, const std::string& path, const httplib::Headers& headers,
                  const std::function<bool(const SseEvent&)>& stop,
                  std::chrono::seconds timeout = std::chrono::seconds(60));

}  // namespace glam::testing
