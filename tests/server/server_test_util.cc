#include "tests/server/server_test_util.h"

#include <unistd.h>

#include <fstream>
#include <vector>
#include <sstream>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

namespace glam::testing {

namespace fs = std::filesystem;


fs::path MakeTinyVideo(const fs::path& dir, int frames) {
  const fs::path path = dir / "tiny.avi";
  cv::VideoWriter writer(path.string(), cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                         10.0, cv::Size(64, 48));
  cv::RNG rng(7);
  for (int i = 0; i < frames; ++i) {
    cv::Mat frame(48, 64, CV_8UC3);
    rng.fill(frame, cv::RNG::UNIFORM, 0, 255);
    writer.write(frame);
  }
  writer.release();
  return path;
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream out;
  out << in.rdbuf();
  return out.str();
}

SseResult ReadSse(httplib::Client& client, const std::string& path, const httplib::Headers& headers,
                  const std::function<bool(const SseEvent&)>& stop, std::chrono::seconds timeout) {
  SseResult result;
  std::string buffer;
  SseEvent current;
  bool stopped = false;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  client.set_read_timeout(timeout);
  auto response = client.Get(
      path, headers,
      [&](const httplib::Response& head) {
        result.status = head.status;
        return true;
      },
      [&](const char* data, std::size_t size) {
        buffer.append(data, size);
        std::size_t line_end;
        while ((line_end = buffer.find('\n')) != std::string::npos) {
          const std::string line = buffer.substr(0, line_end);
          buffer.erase(0, line_end + 1);
          if (line.empty()) {
            if (!current.type.empty()) {
              result.events.push_back(current);
              if (stop(current)) {
                stopped = true;
                return false;
              }
            }
            current = SseEvent{};
          } else if (line.rfind("id: ", 0) == 0) {
            current.id = std::stoll(line.substr(4));
          } else if (line.rfind("event: ", 0) == 0) {
            current.type = line.substr(7);
          } else if (line.rfind("data: ", 0) == 0) {
            current.data = nlohmann::json::parse(line.substr(6));
          }
        }
        return std::chrono::steady_clock::now() < deadline;
      });
  if (response) result.status = response->status;
  result.ended_by_server = !stopped && static_cast<bool>(response);
  return result;
}

}  // namespace glam::testing
