// The fixture of the REST API tests: the real HTTP server and upload probe on a loopback port,
// with a fake engine (fast, deterministic), and the assertion of a documented JSON error.
// Include after any Eigen header (httplib.h, see server_test_util.h).
#pragma once

#include <arpa/inet.h>
#include <sys/resource.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <functional>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "api/job_service.h"
#include "server/http_server.h"
#include "tests/server/server_test_util.h"
#include "tests/support/fake_mapping.h"

namespace glam::server {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using glam::testing::ReadSse;
using glam::testing::SseEvent;
using nlohmann::json;

inline constexpr const char* kTrajectory = "0.0 1 2 3 0 0 0 1\n0.1 1.5 2 3 0 0 0 1\n";

class HttpApiTest : public ::testing::Test {
 protected:
  void Start(HttpServerOptions options = {}, const std::string& name = "api") {
    dir_ = glam::testing::FreshTempDir(name);
    video_ = glam::testing::MakeTinyVideo(dir_);
    Launch(options);
  }

  // Starts the service and the HTTP server on dir_/data (again after Stop(): a restart).
  void Launch(HttpServerOptions options = {}) {
    // A short clip: 6 steps of 5 frames, a submap every 2 steps, held at step 3.
    engine_.steps = 6;
    engine_.frames_per_step = 5;
    engine_.steps_per_submap = 2;
    engine_.hold_step = 3;
    engine_.step_pause = 5ms;
    engine_.trajectory = kTrajectory;
    api::JobServiceOptions service_options;
    service_options.data_dir = dir_ / "data";
    service_options.progress_interval = 0ms;
    service_options.allow_streams = allow_streams_;
    service_options.executor = [this](const api::Job& job, const fs::path& d, const MappingOptions& o,
                                      const ProgressCallback& p, const CancellationToken& c) {
      {
        std::lock_guard lock(ran_mutex_);
        ran_input_ = d / job.input_file;
        ran_max_features_ = o.sift.max_features;
      }
      engine_.Run(d, p, c);
      return report_;
    };
    service_ = std::make_unique<api::JobService>(service_options);
    options.port = 0;
    if (options.max_upload_bytes == HttpServerOptions{}.max_upload_bytes) options.max_upload_bytes = 1 << 20;
    http_ = std::make_unique<HttpServer>(*service_, options);
    port_ = http_->Bind();
    thread_ = std::thread([this] { http_->Run(); });
  }

  void TearDown() override { Stop(); }

  void Stop() {
    if (!http_) return;
    service_->Shutdown();
    http_->Stop();
    thread_.join();
    http_.reset();
    service_.reset();
  }

  httplib::Client Client() {
    httplib::Client client("127.0.0.1", port_);
    client.set_read_timeout(30s);
    if (!token_.empty()) client.set_bearer_token_auth(token_);
    return client;
  }

  httplib::Result UploadMultipart(httplib::Client& client, const std::string& options_json = "") {
    httplib::MultipartFormDataItems items = {
        {"video", glam::testing::ReadFile(video_), "clip.avi", "video/x-msvideo"}};
    if (!options_json.empty()) items.push_back({"options", options_json, "", "application/json"});
    return client.Post("/api/v1/jobs", items);
  }

  std::string CreateJob(httplib::Client& client, const std::string& options_json = "") {
    auto res = UploadMultipart(client, options_json);
    EXPECT_TRUE(res);
    if (!res) return "";
    EXPECT_EQ(res->status, 201) << res->body;
    return json::parse(res->body)["id"];
  }

  std::vector<SseEvent> FollowToEnd(httplib::Client& client, const std::string& id,
                                    httplib::Headers headers = {}) {
    const auto result = ReadSse(client, "/api/v1/jobs/" + id + "/events", headers,
                                [](const SseEvent&) { return false; }, 30s);
    EXPECT_EQ(result.status, 200);
    EXPECT_TRUE(result.ended_by_server);
    return result.events;
  }

  void WaitForHold() {
    const auto deadline = std::chrono::steady_clock::now() + 10s;
    while (!engine_.at_hold && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(2ms);
    ASSERT_TRUE(engine_.at_hold);
  }

  fs::path dir_;
  fs::path video_;
  glam::testing::FakeMapping engine_;
  MappingReport report_;  // what every run reports
  std::mutex ran_mutex_;  // the input and SIFT budget the engine was last run with
  fs::path ran_input_;
  int ran_max_features_ = 0;
  std::string token_;
  bool allow_streams_ = false;  // JobServiceOptions::allow_streams for Start()
  std::unique_ptr<api::JobService> service_;
  std::unique_ptr<HttpServer> http_;
  std::thread thread_;
  int port_ = 0;
};

// Asserts the documented status and a JSON error body with that code.
inline void ExpectError(const httplib::Result& res, int status, const std::string& code, const std::string& what) {
  ASSERT_TRUE(res) << what << ": " << httplib::to_string(res.error());
  EXPECT_EQ(res->status, status) << what << ": " << res->body;
  EXPECT_EQ(res->get_header_value("Content-Type"), "application/json") << what;
  const json body = json::parse(res->body, nullptr, false);
  ASSERT_TRUE(body.is_object() && body.contains("error")) << what << ": " << res->body;
  if (!code.empty()) {
    EXPECT_EQ(body["error"]["code"], code) << what;
  }
  EXPECT_FALSE(body["error"]["message"].get<std::string>().empty()) << what;
}

// Runs `request` while the process may write files of at most `max_file_bytes` (writes past it
// fail with EFBIG, as they would with ENOSPC on a full disk), then lifts the limit again.
inline httplib::Result WithFileSizeLimit(rlim_t max_file_bytes, const std::function<httplib::Result()>& request) {
  std::signal(SIGXFSZ, SIG_IGN);
  rlimit old_limit{};
  EXPECT_EQ(getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  rlimit small = old_limit;
  small.rlim_cur = max_file_bytes;
  EXPECT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  httplib::Result res = request();
  setrlimit(RLIMIT_FSIZE, &old_limit);
  return res;
}

// Starts a request whose head is `head` (request line and headers, without the blank line or
// Content-Length) declaring `declared` body bytes but sending only `sent`, on
// 127.0.0.1:`port`, and returns the open socket: closing it is a link that dropped mid-body;
// keeping it open holds the request (and its upload slot) in the server.
inline int StartRequest(int port, const std::string& head, const std::string& sent, std::size_t declared) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  EXPECT_GE(fd, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  const std::string request = head + "Host: 127.0.0.1\r\nContent-Length: " + std::to_string(declared) + "\r\n\r\n" + sent;
  EXPECT_EQ(::send(fd, request.data(), request.size(), 0), static_cast<ssize_t>(request.size()));
  return fd;
}

// A PATCH of upload `id` from `offset`, as StartRequest.
inline int StartPatch(int port, const std::string& id, std::int64_t offset, const std::string& sent,
                      std::size_t declared) {
  return StartRequest(port,
                      "PATCH /api/v1/uploads/" + id + " HTTP/1.1\r\nContent-Type: application/offset+octet-stream\r\n" +
                          "Upload-Offset: " + std::to_string(offset) + "\r\n",
                      sent, declared);
}

// The job of a POST /jobs answer that must have created a photo job named `name` of `images`
// photos (an empty object when it did not).
inline json CreatedPhotoJob(const httplib::Result& res, const std::string& name, std::size_t images) {
  EXPECT_TRUE(res);
  if (!res) return json::object();
  EXPECT_EQ(res->status, 201) << res->body;
  if (res->status != 201) return json::object();
  const json job = json::parse(res->body);
  EXPECT_EQ(job["name"], name);
  EXPECT_EQ(job["input"]["images"], images);
  EXPECT_EQ(job["input"]["filename"], std::to_string(images) + " photos");
  return job;
}

// A small textured PNG (the real upload probe decodes it).
inline std::string PngPhoto(int seed) {
  cv::Mat image(48, 64, CV_8UC3);
  cv::RNG rng(static_cast<std::uint64_t>(seed));
  rng.fill(image, cv::RNG::UNIFORM, cv::Scalar::all(0), cv::Scalar::all(255));
  std::vector<unsigned char> bytes;
  cv::imencode(".png", image, bytes);
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace glam::server
