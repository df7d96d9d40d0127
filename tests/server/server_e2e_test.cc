// `glam serve` as a real process with the real engine on a tiny synthetic clip (CTest fixture
// synth_server_tiny): a full job followed over SSE and checked against ground truth, cancel
// and restart mid-run, kill -9 mid-job + restart on the same data directory (the job is
// listed, resumes and completes), kill -9 mid-upload (a resumable upload goes on after the
// restart), SIGTERM exits 0 leaving the job resumable, and a live-stream job mapping what an
// ffmpeg sender pushes until it is finished over REST.
#include <signal.h>
#include <cstdlib>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/videoio.hpp>

// Eigen (via the evaluator) before httplib.h, whose <resolv.h> macros break Eigen.
#include "tools/eval/evaluation.h"
#include "tests/server/server_process.h"
#include "tests/support/free_port.h"
#include "tests/server/server_test_util.h"
#include "engine/core/logging.h"
#include "engine/export/tum_trajectory.h"
#include "engine/pipeline/mapping_options.h"
#include "tests/support/colmap_text_model.h"
#include "tests/support/exif_photo.h"
#include "tests/support/unaligned_error.h"
#include "tests/video/test_media.h"

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

TEST(ServerE2E, LiveStreamJobMapsWhatArrivesUntilFinished) {
  // The server listens for the stream (tcp://...?listen=1); an ffmpeg sender pushes the clip in
  // real time over and over, like a drone's feed that never ends, until the client finishes
  // the job over REST. The job must complete with the map of what arrived.
  const fs::path dir = glam::testing::FreshTempDir("e2e_stream");
  const fs::path feed = dir / "feed.ts";
  fs::create_directories(dir);
  ASSERT_TRUE(glam::testing::TranscodeWithFfmpeg(kClip / "video.mp4", feed, "-c copy -f mpegts"));
  ServerProcess server;
  ASSERT_TRUE(server.Start(GLAM_BIN, dir / "data", {"--allow-streams"})) << server.error();
  auto client = ClientFor(server);
  const int port = glam::testing::FreePort();
  const json request = {{"stream_url", fmt::format("tcp://127.0.0.1:{}?listen=1", port)},
                        {"options", {{"name", "live"}, {"keyframes_per_submap", 6}}}};
  auto res = client.Post("/api/v1/jobs", request.dump(), "application/json");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  const std::string id = json::parse(res->body)["id"];

  const pid_t sender = fork();
  ASSERT_GE(sender, 0);
  if (sender == 0) {
    setpgid(0, 0);
    const std::string command = fmt::format(
        "for i in $(seq 300); do ffmpeg -nostdin -v error -re -stream_loop -1 -i '{}' -c copy -f mpegts "
        "tcp://127.0.0.1:{} && exit 0; sleep 0.1; done",
        feed.string(), port);
    execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  WaitForProgress(client, id, 60);
  res = client.Post("/api/v1/jobs/" + id + "/finish");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200) << res->body;
  const std::string state = FollowToEnd(client, id);
  kill(-sender, SIGKILL);
  waitpid(sender, nullptr, 0);
  ASSERT_EQ(state, "completed") << GetJob(client, id).dump();

  res = client.Get("/api/v1/jobs/" + id + "/report.json");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);
  const json report = json::parse(res->body);
  EXPECT_TRUE(report["input_is_stream"].get<bool>());
  EXPECT_GE(report["frames_decoded"].get<int>(), 60);
  res = client.Get("/api/v1/jobs/" + id + "/trajectory.tum");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);
  const fs::path result_dir = dir / "result";
  fs::create_directories(result_dir);
  std::ofstream(result_dir / "trajectory.tum") << res->body;
  // The first pass of the clip is the ground truth's time range (a repeat comes after it).
  const eval::EvaluationResult evaluation = eval::EvaluateDirectories(kClip, result_dir, {});
  EXPECT_GT(evaluation.trajectory.fraction_posed, 0.5) << eval::Summary(evaluation);
  EXPECT_LT(evaluation.trajectory.ate_rmse, 1.5) << eval::Summary(evaluation);
  server.Signal(SIGTERM);
  EXPECT_EQ(server.Wait(30), 0);
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

// A photo job: every 3rd frame of the clip as a JPEG tagged with its true position (EXIF GPS,
// as a drone camera writes it), uploaded as "images" fields in shuffled order. The server maps
// the folder in name order with the photo feature budget and georeferences it from the EXIF:
// the camera centres come out in metres, east-north-up, where the photos were taken.
TEST(ServerE2E, PhotoJobIsMappedAndGeoreferencedFromExif) {
  const fs::path dir = glam::testing::FreshTempDir("e2e_photos");
  const std::vector<TimedPose> truth = ReadTumTrajectory(kClip / "gt_trajectory.tum");
  const EnuFrame frame({46.95, 7.45, 550.0});
  cv::VideoCapture video((kClip / "video.mp4").string(), cv::CAP_FFMPEG);
  ASSERT_TRUE(video.isOpened());
  constexpr std::size_t kEvery = 3;
  std::vector<std::size_t> frame_of_photo;
  httplib::MultipartFormDataItems items;
  cv::Mat image;
  for (std::size_t i = 0; video.read(image); ++i) {
    if (i % kEvery != 0) continue;
    const Geodetic g = frame.GeodeticFromEnu(truth[i].world_from_cam.translation());
    const std::string name = fmt::format("DJI_{:04}.JPG", frame_of_photo.size());
    glam::testing::WritePhoto(dir / name, image, &g);
    items.push_back({"images", glam::testing::ReadFile(dir / name), name, "image/jpeg"});
    frame_of_photo.push_back(i);
  }
  std::reverse(items.begin(), items.end());  // the folder is mapped in name order anyway
  items.push_back({"options", R"({"name": "photos"})", "", "application/json"});

  ServerProcess server;
  ASSERT_TRUE(server.Start(GLAM_BIN, dir / "data")) << server.error();
  auto client = ClientFor(server);
  auto res = client.Post("/api/v1/jobs", items);
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  const std::string id = json::parse(res->body)["id"];
  EXPECT_EQ(json::parse(res->body)["input"]["images"], frame_of_photo.size());
  ASSERT_EQ(FollowToEnd(client, id), "completed") << GetJob(client, id).dump();

  res = client.Get("/api/v1/jobs/" + id + "/report.json");
  ASSERT_TRUE(res);
  const json report = json::parse(res->body);
  EXPECT_EQ(report["sift_max_features"], kPhotoFolderMaxFeatures);
  ASSERT_EQ(report["georeference"]["ok"], true) << report["georeference"].dump();
  EXPECT_EQ(report["georeference"]["gps_track"], "EXIF GPS of the photos");
  res = client.Get("/api/v1/jobs/" + id + "/trajectory.tum");
  ASSERT_TRUE(res);
  std::ofstream(dir / "trajectory.tum") << res->body;
  const std::vector<TimedPose> mapped = ReadTumTrajectory(dir / "trajectory.tum");
  ASSERT_GT(mapped.size(), frame_of_photo.size() * 8 / 10);
  // The ENU origin is the first photo's position (the first frame's true centre).
  const Eigen::Vector3d shift = truth.front().world_from_cam.translation();
  std::size_t compared = 0;
  const double rms = glam::testing::UnalignedCentreRms(mapped, truth, shift, glam::testing::PhotoFrames(frame_of_photo),
                                                       &compared);
  EXPECT_EQ(compared, mapped.size());
  GLAM_LOG_INFO("photo job: {} of {} photos posed, {:.3f} m rms from the truth", mapped.size(), frame_of_photo.size(), rms);
  // Exact GPS, so what is left is the map's own error (the clip flies ~100 m up).
  EXPECT_LT(rms, 1.0);

  // The same photos through `glam upload FOLDER`: a resumable image set, one photo per
  // request, mapped as the same photo job.
  fs::create_directories(dir / "survey");
  for (const fs::directory_entry& e : fs::directory_iterator(dir)) {
    if (e.path().extension() == ".JPG") fs::copy_file(e.path(), dir / "survey" / e.path().filename());
  }
  const std::string command = std::string(GLAM_BIN) + " --log-level warn upload " + (dir / "survey").string() +
                              " --server http://127.0.0.1:" + std::to_string(server.port()) + " --follow --download " +
                              (dir / "via_cli").string() + " > " + (dir / "cli.txt").string() + " 2> " +
                              (dir / "cli_err.txt").string();
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << glam::testing::ReadFile(dir / "cli_err.txt");
  const json created = json::parse(glam::testing::ReadFile(dir / "cli.txt"));
  EXPECT_EQ(created["input"]["images"], frame_of_photo.size());
  EXPECT_EQ(created["name"], "survey");  // the folder's name
  // Its COLMAP model (downloaded to via_cli/colmap) names the images by their photos, and
  // each one's camera sits where that photo's EXIF put it (within the map's error).
  const glam::testing::ColmapTextModel colmap = glam::testing::ReadColmapTextModel(dir / "via_cli" / "colmap");
  ASSERT_GE(colmap.images.size(), 3u);
  double colmap_sum = 0;
  for (const auto& [image_id, photo] : colmap.images) {
    ASSERT_EQ(photo.name.substr(0, 4), "DJI_") << photo.name;
    const std::size_t number = std::stoul(photo.name.substr(4, 4));  // DJI_0012.JPG
    ASSERT_LT(number, frame_of_photo.size()) << photo.name;
    EXPECT_TRUE(fs::is_regular_file(dir / "survey" / photo.name)) << photo.name;
    colmap_sum += (photo.Centre() + shift - truth[frame_of_photo[number]].world_from_cam.translation()).squaredNorm();
  }
  EXPECT_LT(std::sqrt(colmap_sum / static_cast<double>(colmap.images.size())), 1.0);
  const json cli_report = json::parse(glam::testing::ReadFile(dir / "via_cli" / "report.json"));
  EXPECT_EQ(cli_report["georeference"]["ok"], true);
  const std::vector<TimedPose> via_cli = ReadTumTrajectory(dir / "via_cli" / "trajectory.tum");
  EXPECT_EQ(via_cli.size(), mapped.size());
  EXPECT_LT(glam::testing::UnalignedCentreRms(via_cli, truth, shift, glam::testing::PhotoFrames(frame_of_photo),
                                              &compared),
            1.0);
  EXPECT_TRUE(fs::is_empty(dir / "data" / "resumable"));

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

// A resumable upload cut by kill -9 of the server: after the restart the bytes that were
// confirmed are there, the client sends the rest, and the video maps like any other.
TEST(ServerE2E, KilledServerKeepsAResumableUpload) {
  const fs::path dir = glam::testing::FreshTempDir("e2e_kill_upload");
  const std::string video = glam::testing::ReadFile(kClip / "video.mp4");
  const std::size_t half = video.size() / 2;
  std::string upload_id;
  {
    ServerProcess server;
    ASSERT_TRUE(server.Start(GLAM_BIN, dir / "data")) << server.error();
    auto client = ClientFor(server);
    auto res = client.Post("/api/v1/uploads", json{{"size", video.size()}, {"filename", "tiny.mp4"}}.dump(),
                           "application/json");
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 201) << res->body;
    upload_id = json::parse(res->body)["id"];
    res = client.Patch("/api/v1/uploads/" + upload_id, {{"Upload-Offset", "0"}}, video.substr(0, half),
                       "application/offset+octet-stream");
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200) << res->body;
    server.Signal(SIGKILL);
    EXPECT_EQ(server.Wait(10), 128 + SIGKILL);
  }
  ServerProcess server;
  ASSERT_TRUE(server.Start(GLAM_BIN, dir / "data")) << server.error();
  auto client = ClientFor(server);
  auto res = client.Get("/api/v1/uploads/" + upload_id);
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << "upload lost after kill -9: " << res->body;
  ASSERT_EQ(json::parse(res->body)["offset"], half);
  res = client.Patch("/api/v1/uploads/" + upload_id, {{"Upload-Offset", std::to_string(half)}}, video.substr(half),
                     "application/offset+octet-stream");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;
  EXPECT_EQ(json::parse(res->body)["complete"], true);
  res = client.Post("/api/v1/jobs", json{{"upload_id", upload_id}, {"options", json::parse(kOptions)}}.dump(),
                    "application/json");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  const std::string id = json::parse(res->body)["id"];
  EXPECT_EQ(FollowToEnd(client, id), "completed") << GetJob(client, id).dump();
  const json job = GetJob(client, id);
  EXPECT_EQ(job["input"]["size_bytes"], video.size());
  EXPECT_GT(job["progress"]["points"].get<int>(), 0);
  server.Signal(SIGTERM);
  EXPECT_EQ(server.Wait(30), 0);
}

// `glam upload` as a user runs it: the clip (with its GPS track found beside it) in small
// chunks, the job followed to the end, the results downloaded; a bad option exits 2 before
// anything is sent.
TEST(ServerE2E, GlamUploadSendsFollowsAndDownloads) {
  const fs::path dir = glam::testing::FreshTempDir("e2e_glam_upload");
  ServerProcess server;
  ASSERT_TRUE(server.Start(GLAM_BIN, dir / "data", {"--token", "t0ken"})) << server.error();
  fs::copy_file(kClip / "video.mp4", dir / "DJI_0007.MP4");
  const std::string url = "http://127.0.0.1:" + std::to_string(server.port());
  const std::string base = std::string(GLAM_BIN) + " --log-level warn upload " + (dir / "DJI_0007.MP4").string() +
                           " --server " + url;
  auto run = [&](const std::string& extra) {
    const int status = std::system((base + " " + extra + " > " + (dir / "out.txt").string() + " 2> " +
                                    (dir / "err.txt").string())
                                       .c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  EXPECT_EQ(run("--token t0ken --options '{\"stride\": 0}'"), 2) << glam::testing::ReadFile(dir / "err.txt");
  EXPECT_EQ(run("--token wrong"), 2) << glam::testing::ReadFile(dir / "err.txt");  // 401: refused
  ASSERT_EQ(run("--token t0ken --no-gps --chunk-mb 0.05 --options '" + std::string(kOptions) +
                "' --follow --download " + (dir / "results").string()),
            0)
      << glam::testing::ReadFile(dir / "err.txt");
  const json created = json::parse(glam::testing::ReadFile(dir / "out.txt"));
  EXPECT_EQ(created["name"], "tiny");
  EXPECT_EQ(created["input"]["filename"], "DJI_0007.MP4");
  for (const char* name : {"trajectory.tum", "points.ply", "report.json", "graph.json", "map.glb",
                           "colmap/cameras.txt", "colmap/images.txt", "colmap/points3D.txt"}) {
    EXPECT_TRUE(fs::is_regular_file(dir / "results" / name)) << name;
  }
  const json report = json::parse(glam::testing::ReadFile(dir / "results" / "report.json"));
  EXPECT_GT(report["frames_posed"].get<int>(), 0);
  server.Signal(SIGTERM);
  EXPECT_EQ(server.Wait(30), 0);
}

}  // namespace
}  // namespace glam::server
