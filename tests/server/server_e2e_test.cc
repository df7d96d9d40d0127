// `glam serve` as a real process with the real engine on a tiny synthetic clip (CTest fixture
// synth_server_tiny): a full job followed over SSE and checked against ground truth, cancel
// and restart mid-run, kill -9 mid-job + restart on the same data directory (the job is
// listed, resumes and completes), and SIGTERM exits 0 leaving the job resumable.
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

// Eigen (via the evaluator) before httplib.h, whose <resolv.h> macros break Eigen.
#include "tools/eval/evaluation.h"
#include "tests/server/server_process.h"
#include "tests/server/server_test_util.h"

namespace glam::server {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using glam::testing::ReadSse;
using glam::testing::ServerProcess;
using glam::testing::SseEvent;
using nlohmann::json;

const fs::path kClip = fs::path(GLAM_TEST_FIXTURES_DIR) / "server_tiny";
constexpr const char* kOptions = R"({"name": "tiny", "keyframes_per_submap": 6})";

httplib::Client ClientFor(const ServerProcess& server) {
  httplib::Client client("127.0.0.1", server.port());
  client.set_read_timeout(60s);
  return client;
}

std::string Upload(httplib::Client& client) {
  httplib::MultipartFormDataItems items = {
      {"video", glam::testing::ReadFile(kClip / "video.mp4"), "video.mp4", "video/mp4"},
      {"options", kOptions, "", "application/json"}};
  auto res = client.Post("/api/v1/jobs", items);
  EXPECT_TRUE(res);
  if (!res) return "";
  EXPECT_EQ(res->status, 201) << res->body;
  return json::parse(res->body)["id"];
}

json GetJob(httplib::Client& client, const std::string& id) {
  auto res = client.Get("/api/v1/jobs/" + id);
  if (!res || res->status != 200) return json();
  return json::parse(res->body);
}

// Follows events until the stream ends; returns the last state seen.
std::string FollowToEnd(httplib::Client& client, const std::string& id, std::int64_t after = 0,
                        std::vector<SseEvent>* events = nullptr) {
  httplib::Headers headers;
  if (after > 0) headers.emplace("Last-Event-ID", std::to_string(after));
  const auto result = ReadSse(client, "/api/v1/jobs/" + id + "/events", headers,
                              [](const SseEvent&) { return false; }, 240s);
  std::string state;
  for (const SseEvent& e : result.events) {
    if (e.type == "state") state = e.data["state"];
  }
  if (events != nullptr) *events = result.events;
  return state;
}

// Waits until the job's events show mapping progress (frames decoded), returns the last id.
std::int64_t WaitForProgress(httplib::Client& client, const std::string& id, std::int64_t min_frames) {
  std::int64_t last_id = 0;
  ReadSse(client, "/api/v1/jobs/" + id + "/events", {}, [&](const SseEvent& e) {
    last_id = e.id;
    return e.type == "progress" && e.data["frames_done"].get<std::int64_t>() >= min_frames;
  }, 120s);
  return last_id;
}

TEST(ServerE2E, FullJobOverHttpMatchesGroundTruth) {
  const fs::path dir = glam::testing::FreshTempDir("e2e_full");
  ServerProcess server;
  ASSERT_TRUE(server.Start(GLAM_BIN, dir / "data")) << server.error();
  auto client = ClientFor(server);
  const std::string id = Upload(client);
  ASSERT_FALSE(id.empty());
  std::vector<SseEvent> events;
  ASSERT_EQ(FollowToEnd(client, id, 0, &events), "completed") << GetJob(client, id).dump();
  int submaps = 0;
  for (const SseEvent& e : events) submaps += e.type == "submap" ? 1 : 0;
  const json job = GetJob(client, id);
  EXPECT_EQ(job["state"], "completed");
  EXPECT_GE(submaps, 1);
  EXPECT_EQ(submaps, job["progress"]["submaps_completed"].get<int>());

  auto res = client.Get("/api/v1/jobs/" + id + "/trajectory.tum");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);
  const fs::path result_dir = dir / "result";
  fs::create_directories(result_dir);
  std::ofstream(result_dir / "trajectory.tum") << res->body;
  eval::EvaluationOptions options;
  const eval::EvaluationResult evaluation = eval::EvaluateDirectories(kClip, result_dir, options);
  EXPECT_GT(evaluation.trajectory.fraction_posed, 0.5);
  // The clip flies ~100 m above ground; metres-level shape error would be a broken map.
  EXPECT_LT(evaluation.trajectory.ate_rmse, 1.5) << eval::Summary(evaluation);

  res = client.Get("/api/v1/jobs/" + id + "/report.json");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_TRUE(json::parse(res->body, nullptr, false).is_object());
  res = client.Get("/api/v1/jobs/" + id + "/points.ply", {{"Range", "bytes=0-2"}});
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 206);
  EXPECT_EQ(res->body, "ply");

  server.Signal(SIGTERM);
  EXPECT_EQ(server.Wait(30), 0);
}

TEST(ServerE2E, CancelMidRunThenRestart) {
  const fs::path dir = glam::testing::FreshTempDir("e2e_cancel");
  ServerProcess server;
  ASSERT_TRUE(server.Start(GLAM_BIN, dir / "data")) << server.error();
  auto client = ClientFor(server);
  const std::string id = Upload(client);
  ASSERT_FALSE(id.empty());
  WaitForProgress(client, id, 5);
  auto res = client.Post("/api/v1/jobs/" + id + "/cancel");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(json::parse(res->body)["state"], "canceled");
  res = client.Post("/api/v1/jobs/" + id + "/restart");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  WaitForProgress(client, id, 5);
  EXPECT_EQ(GetJob(client, id)["state"], "running");
  res = client.Delete("/api/v1/jobs/" + id);
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 204);
  EXPECT_FALSE(fs::exists(dir / "data" / "jobs" / id));
  server.Signal(SIGTERM);
  EXPECT_EQ(server.Wait(30), 0);
}

TEST(ServerE2E, KilledServerResumesTheJobAfterRestart) {
  const fs::path dir = glam::testing::FreshTempDir("e2e_kill");
  std::string id;
  std::int64_t seen_id = 0;
  {
    ServerProcess server;
    ASSERT_TRUE(server.Start(GLAM_BIN, dir / "data")) << server.error();
    auto client = ClientFor(server);
    id = Upload(client);
    ASSERT_FALSE(id.empty());
    seen_id = WaitForProgress(client, id, 10);
    server.Signal(SIGKILL);
    EXPECT_EQ(server.Wait(10), 128 + SIGKILL);
  }
  {
    // Graceful stop mid-job: exit 0, the job stays resumable.
    ServerProcess server;
    ASSERT_TRUE(server.Start(GLAM_BIN, dir / "data")) << server.error();
    auto client = ClientFor(server);
    const json job = GetJob(client, id);
    ASSERT_TRUE(job.is_object()) << "job lost after kill -9";
    EXPECT_TRUE(job["state"] == "queued" || job["state"] == "running") << job.dump();
    WaitForProgress(client, id, 1);
    server.Signal(SIGTERM);
    EXPECT_EQ(server.Wait(60), 0);
  }
  ServerProcess server;
  ASSERT_TRUE(server.Start(GLAM_BIN, dir / "data")) << server.error();
  auto client = ClientFor(server);
  std::vector<SseEvent> events;
  // Resuming the stream from before the crash: nothing is replayed twice, ids keep growing.
  EXPECT_EQ(FollowToEnd(client, id, seen_id, &events), "completed") << GetJob(client, id).dump();
  ASSERT_FALSE(events.empty());
  EXPECT_GT(events.front().id, seen_id);
  auto res = client.Get("/api/v1/jobs/" + id + "/trajectory.tum");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_FALSE(res->body.empty());
  res = client.Get("/api/v1/jobs");
  ASSERT_TRUE(res);
  EXPECT_EQ(json::parse(res->body)["total"], 1);
  server.Signal(SIGTERM);
  EXPECT_EQ(server.Wait(30), 0);
}

}  // namespace
}  // namespace glam::server
