// The REST API over real HTTP on a loopback port, with the real upload probe but a fake
// engine (fast, deterministic): status codes and JSON errors, auth, path traversal, SSE replay,
// downloads with ETag / Range, concurrent uploads, and that openapi.yaml documents every route.

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <regex>
#include <set>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "api/job_service.h"
#include "engine/core/error.h"
#include "engine/map/submap_io.h"
#include "engine/pipeline/tile_writer.h"
#include "server/http_server.h"
#include "tests/server/http_api_fixture.h"

namespace glam::server {
namespace {

TEST_F(HttpApiTest, UploadFollowEventsAndDownload) {
  Start();
  auto client = Client();
  auto res = UploadMultipart(client, R"({"name": "survey", "stride": 1})");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  const json job = json::parse(res->body);
  const std::string id = job["id"];
  EXPECT_EQ(res->get_header_value("Location"), "/api/v1/jobs/" + id);
  EXPECT_EQ(job["name"], "survey");
  EXPECT_EQ(job["input"]["width"], 64);
  EXPECT_EQ(job["urls"]["events"], "/api/v1/jobs/" + id + "/events");

  const auto events = FollowToEnd(client, id);
  ASSERT_FALSE(events.empty());
  std::vector<std::string> states;
  int submaps = 0;
  for (std::size_t i = 0; i < events.size(); ++i) {
    if (i > 0) {
      EXPECT_GT(events[i].id, events[i - 1].id);
    }
    if (events[i].type == "state") states.push_back(events[i].data["state"]);
    if (events[i].type == "submap") ++submaps;
  }
  EXPECT_EQ(states.back(), "completed");
  EXPECT_EQ(events.back().type, "state");  // the stream ends after the final state event
  EXPECT_EQ(submaps, 3);

  res = client.Get("/api/v1/jobs/" + id);
  ASSERT_TRUE(res);
  EXPECT_EQ(json::parse(res->body)["state"], "completed");
  EXPECT_EQ(json::parse(res->body)["progress"]["frames_done"], 30);

  res = client.Get("/api/v1/jobs/" + id + "/trajectory.tum");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->body, kTrajectory);
  EXPECT_EQ(res->get_header_value("Content-Type"), "text/plain; charset=utf-8");
  const std::string etag = res->get_header_value("ETag");
  ASSERT_FALSE(etag.empty());
  res = client.Get("/api/v1/jobs/" + id + "/trajectory.tum", {{"If-None-Match", etag}});
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 304);
  EXPECT_TRUE(res->body.empty());
  res = client.Get("/api/v1/jobs/" + id + "/trajectory.tum", {{"Range", "bytes=4-9"}});
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 206);
  EXPECT_EQ(res->body, std::string(kTrajectory).substr(4, 6));
  EXPECT_EQ(res->get_header_value("Content-Range"), "bytes 4-9/" + std::to_string(std::string(kTrajectory).size()));
  ExpectError(client.Get("/api/v1/jobs/" + id + "/trajectory.tum", {{"Range", "bytes=9999-"}}), 416, "", "range");
  ExpectError(client.Get("/api/v1/jobs/" + id + "/points.ply"), 404, "not_found", "missing result");
  // trajectory.geojson: only a georeferenced map has one (the 404 says so); served as GeoJSON.
  res = client.Get("/api/v1/jobs/" + id + "/trajectory.geojson");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 404);
  EXPECT_NE(res->body.find("georeferenced maps only"), std::string::npos) << res->body;
  const std::string geojson = R"({"type":"FeatureCollection","features":[]})";
  std::ofstream(dir_ / "data" / "jobs" / id / "trajectory.geojson") << geojson;
  res = client.Get("/api/v1/jobs/" + id + "/trajectory.geojson");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->body, geojson);
  EXPECT_EQ(res->get_header_value("Content-Type"), "application/geo+json");
  ExpectError(client.Get("/api/v1/jobs/" + id + "/tileset.json"), 404, "not_available", "tiles");
  ExpectError(client.Get("/api/v1/jobs/" + id + "/tiles/0.glb"), 404, "not_available", "tile");
  // The COLMAP text model (colmap/), linked from the job's urls.
  const json urls = json::parse(client.Get("/api/v1/jobs/" + id)->body)["urls"];
  EXPECT_EQ(urls["colmap_images"], "/api/v1/jobs/" + id + "/colmap/images.txt");
  ExpectError(client.Get(urls["colmap_points3D"].get<std::string>()), 404, "not_found", "no COLMAP model");
  fs::create_directories(dir_ / "data" / "jobs" / id / "colmap");
  const std::string cameras = "1 PINHOLE 640 360 500 500 320 180\n";
  std::ofstream(dir_ / "data" / "jobs" / id / "colmap" / "cameras.txt") << cameras;
  res = client.Get(urls["colmap_cameras"].get<std::string>());
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->body, cameras);
  EXPECT_EQ(res->get_header_value("Content-Type"), "text/plain; charset=utf-8");
  ExpectError(client.Get("/api/v1/jobs/" + id + "/colmap/project.ini"), 404, "", "not a COLMAP model file");

  res = client.Get("/api/v1/jobs?limit=10");
  ASSERT_TRUE(res);
  const json page = json::parse(res->body);
  EXPECT_EQ(page["total"], 1);
  EXPECT_EQ(page["jobs"][0]["id"], id);
}

// Disconnected parts of a completed job (report.json "parts", written by the engine's map
// export to parts/<n>/) are served under /parts/<n>/; bad part names are 400, missing parts 404.
TEST_F(HttpApiTest, DisconnectedPartsAreServedByNumber) {
  Start({}, "parts");
  PartExport reported;
  reported.number = 1;
  reported.submaps = {3, 4};
  reported.first_frame = 300;
  reported.last_frame = 449;
  reported.frames_posed = 150;
  reported.points = 900;
  report_.parts = {reported};
  auto client = Client();
  engine_.hold = true;
  const std::string id = CreateJob(client);
  const std::string base = "/api/v1/jobs/" + id + "/";
  // While running the job JSON lists no parts; once completed, the report's.
  WaitForHold();
  EXPECT_EQ(json::parse(client.Get(base.substr(0, base.size() - 1))->body)["parts"], json::array());
  engine_.hold = false;
  FollowToEnd(client, id);
  const json job = json::parse(client.Get(base.substr(0, base.size() - 1))->body);
  ASSERT_EQ(job["parts"].size(), 1u) << job.dump();
  EXPECT_EQ(job["parts"][0]["part"], 1);
  EXPECT_EQ(job["parts"][0]["first_frame"], 300);
  EXPECT_EQ(job["parts"][0]["last_frame"], 449);
  EXPECT_EQ(job["parts"][0]["frames_posed"], 150);
  EXPECT_EQ(job["parts"][0]["points"], 900);
  EXPECT_EQ(job["parts"][0]["urls"]["trajectory"], base + "parts/1/trajectory.tum");
  EXPECT_EQ(job["parts"][0]["urls"]["points"], base + "parts/1/points.ply");
  EXPECT_EQ(job["parts"][0]["urls"]["colmap_points3D"], base + "parts/1/colmap/points3D.txt");
  // Listed jobs carry them too (the web viewer's job list links them).
  EXPECT_EQ(json::parse(client.Get("/api/v1/jobs")->body)["jobs"][0]["parts"], job["parts"]);
  const fs::path part_dir = dir_ / "data" / "jobs" / id / "parts" / "1";
  fs::create_directories(part_dir);
  const std::string part_trajectory = "2.0 5 0 0 0 0 0 1\n";
  std::ofstream(part_dir / "trajectory.tum") << part_trajectory;
  std::ofstream(part_dir / "points.ply") << "ply\n";
  auto res = client.Get(base + "parts/1/trajectory.tum");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->body, part_trajectory);
  EXPECT_EQ(res->get_header_value("Content-Type"), "text/plain; charset=utf-8");
  res = client.Get(base + "parts/1/points.ply");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->body, "ply\n");
  fs::create_directories(part_dir / "colmap");
  std::ofstream(part_dir / "colmap" / "images.txt") << "# no images\n";
  res = client.Get(base + "parts/1/colmap/images.txt");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->body, "# no images\n");
  ExpectError(client.Get(base + "parts/2/trajectory.tum"), 404, "not_found", "no such part");
  ExpectError(client.Get(base + "parts/0/trajectory.tum"), 400, "bad_request", "parts count from 1");
  ExpectError(client.Get(base + "parts/one/points.ply"), 400, "bad_request", "not a number");
  ExpectError(client.Get(base + "parts/1/report.json"), 404, "", "only the part's trajectory and points");
  ExpectError(client.Get("/api/v1/jobs/0123456789abcdef/parts/1/trajectory.tum"), 404, "not_found", "unknown job");
}

// Map tiles written by the engine's TileWriter into a job directory are served as they appear:
// tiles immutable, tileset.json revalidated by ETag and replaced per revision, the quantized
// variants by ?format=quantized (and under the names the quantized tileset's URIs use).
TEST_F(HttpApiTest, MapTilesTilesetAndFormatsAreServed) {
  Start({}, "tiles");
  auto client = Client();
  const std::string id = CreateJob(client);
  FollowToEnd(client, id);
  const fs::path job_dir = dir_ / "data" / "jobs" / id;
  const std::string base = "/api/v1/jobs/" + id + "/";
  ExpectError(client.Get(base + "tileset.json?format=quantized"), 404, "not_available", "no tileset yet");

  Submap submap;
  submap.id = 0;
  submap.last_frame = 9;
  for (int i = 0; i < 50; ++i) {
    Landmark lm;
    lm.point_in_submap = Eigen::Vector3d(i % 10, i / 10, 0.1 * i);
    lm.color = {static_cast<std::uint8_t>(i), 100, 200};
    submap.landmarks.push_back(lm);
  }
  WriteSubmap(submap, job_dir / "submaps");
  TileWriter tiles(job_dir, "r1");
  tiles.OnSubmapCompleted(submap);
  MapSnapshot snapshot;
  snapshot.revision = 1;
  snapshot.submaps.push_back(SubmapPlacement{});
  tiles.OnRevision(snapshot);

  auto res = client.Get(base + "tiles/0.glb");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->body, glam::testing::ReadFile(job_dir / "tiles" / "0.glb"));
  EXPECT_EQ(res->body.substr(0, 4), "glTF");
  EXPECT_EQ(res->get_header_value("Content-Type"), "model/gltf-binary");
  EXPECT_NE(res->get_header_value("Cache-Control").find("immutable"), std::string::npos);
  const std::string quantized_tile = glam::testing::ReadFile(job_dir / "tiles" / "0.quantized.glb");
  EXPECT_NE(quantized_tile, res->body);
  res = client.Get(base + "tiles/0.glb?format=quantized");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->body, quantized_tile);
  EXPECT_NE(res->get_header_value("Cache-Control").find("immutable"), std::string::npos);
  res = client.Get(base + "tiles/0.glb?format=draco");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->body, glam::testing::ReadFile(job_dir / "tiles" / "0.glb"));
  ExpectError(client.Get(base + "tiles/0.glb?format=obj"), 400, "bad_request", "unknown format");
  ExpectError(client.Get(base + "tiles/1.glb?format=quantized"), 404, "not_available", "tile not written");
  ExpectError(client.Get(base + "tiles/x.quantized.glb"), 400, "bad_request", "bad quantized tile name");

  res = client.Get(base + "tileset.json");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->get_header_value("Content-Type"), "application/json");
  EXPECT_EQ(res->get_header_value("Cache-Control"), "no-cache");
  const std::string etag = res->get_header_value("ETag");
  ASSERT_FALSE(etag.empty());
  json tileset = json::parse(res->body);
  EXPECT_EQ(tileset["extras"]["revision"], 1);
  EXPECT_EQ(tileset["root"]["children"][0]["content"]["uri"], "tiles/0.glb?v=r1");
  res = client.Get(base + "tileset.json", {{"If-None-Match", etag}});
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 304);

  // Every content URI of the quantized tileset, resolved against the tileset's URL, is served.
  res = client.Get(base + "tileset.json?format=quantized");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);
  const json quantized = json::parse(res->body);
  ASSERT_EQ(quantized["root"]["children"].size(), 1u);
  const std::string uri = quantized["root"]["children"][0]["content"]["uri"];
  res = client.Get(base + uri);
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200) << uri;
  EXPECT_EQ(res->body, quantized_tile);

  // A new revision replaces the tileset: the old ETag no longer matches.
  snapshot.revision = 2;
  snapshot.submaps[0].world_from_submap = Sim3(2.0, SO3(), Eigen::Vector3d(1, 2, 3));
  tiles.OnRevision(snapshot);
  res = client.Get(base + "tileset.json", {{"If-None-Match", etag}});
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  tileset = json::parse(res->body);
  EXPECT_EQ(tileset["asset"]["tilesetVersion"], "2");
  EXPECT_EQ(tileset["root"]["children"][0]["transform"][0], 2.0);

  // The open submap's preview: listed in both tilesets under a versioned URI that the server
  // resolves (Draco and quantized), revalidated instead of cached for good.
  Submap open = submap;
  open.id = 1;
  open.frame_poses.push_back(FramePose{});
  ASSERT_TRUE(tiles.OnOpenSubmapPreview(open, 0u, Sim3()));
  for (const std::string format : {"", "?format=quantized"}) {
    res = client.Get(base + "tileset.json" + format);
    ASSERT_TRUE(res);
    const json with_open = json::parse(res->body);
    ASSERT_EQ(with_open["root"]["children"].size(), 2u) << format;
    const json& child = with_open["root"]["children"][1];
    EXPECT_EQ(child["extras"]["open"], true);
    const std::string open_uri = child["content"]["uri"];
    EXPECT_NE(open_uri.find("open"), std::string::npos) << open_uri;
    res = client.Get(base + open_uri);
    ASSERT_TRUE(res);
    EXPECT_EQ(res->status, 200) << open_uri;
    EXPECT_EQ(res->body, glam::testing::ReadFile(job_dir / open_uri.substr(0, open_uri.find('?'))));
    EXPECT_EQ(res->get_header_value("Cache-Control"), "no-cache") << open_uri;
  }
  ExpectError(client.Get(base + "tiles/x.open.glb"), 400, "bad_request", "bad open tile name");
  tiles.ClearOpenPreview();
  ExpectError(client.Get(base + "tiles/1.open.glb"), 404, "not_available", "preview gone");

  EXPECT_EQ(tiles.WriteMapGlb(snapshot, job_dir / "submaps"), 50);
  res = client.Get(base + "map.glb");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->get_header_value("Cache-Control"), "no-cache");
  EXPECT_EQ(res->body, glam::testing::ReadFile(job_dir / "map.glb"));
}

// A multipart upload may carry the video's GPS track (field "telemetry", a DJI .SRT): it is
// checked, stored beside the video as the engine's sidecar (input.SRT) and kept on restart;
// an unreadable one is refused before the job exists.
TEST_F(HttpApiTest, TelemetryIsStoredBesideTheVideo) {
  Start({}, "telemetry");
  auto client = Client();
  const std::string srt =
      "1\n00:00:00,000 --> 00:00:00,033\n[latitude: 46.5] [longitude: 7.5] [rel_alt: 50.0 abs_alt: 1250.0]\n\n"
      "2\n00:00:00,033 --> 00:00:00,066\n[latitude: 46.50001] [longitude: 7.5] [rel_alt: 50.0 abs_alt: 1250.0]\n";
  httplib::MultipartFormDataItems items = {
      {"video", glam::testing::ReadFile(video_), "DJI_0001.MP4", "video/mp4"},
      {"telemetry", srt, "DJI_0001.SRT", "application/x-subrip"}};
  auto res = client.Post("/api/v1/jobs", items);
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  const std::string id = json::parse(res->body)["id"];
  const fs::path job_dir = dir_ / "data" / "jobs" / id;
  FollowToEnd(client, id);
  EXPECT_EQ(glam::testing::ReadFile(job_dir / "input.SRT"), srt);
  res = client.Post("/api/v1/jobs/" + id + "/restart");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;
  EXPECT_TRUE(fs::exists(job_dir / "input.SRT"));  // kept with the video
  FollowToEnd(client, id);

  const std::size_t jobs_before = json::parse(client.Get("/api/v1/jobs")->body)["total"];
  items[1].content = "1\n00:00:00,000 --> 00:00:01,000\nno positions\n";
  ExpectError(client.Post("/api/v1/jobs", items), 400, "bad_telemetry", "telemetry without positions");
  EXPECT_EQ(json::parse(client.Get("/api/v1/jobs")->body)["total"], jobs_before);
}

TEST_F(HttpApiTest, PhotosUploadedAsImagesFieldsBecomeAPhotoFolderJob) {
  Start({}, "photos");
  auto client = Client();
  httplib::MultipartFormDataItems items = {
      {"images", PngPhoto(1), "flight/DJI_0002.png", "image/png"},
      {"images", PngPhoto(2), "../../DJI_0001.png", "image/png"},  // a path trick: stays inside
      {"images", PngPhoto(3), "DJI 0003.png", "image/png"},
      {"options", R"({"name": "survey"})", "", "application/json"}};
  auto res = client.Post("/api/v1/jobs", items);
  const json job = CreatedPhotoJob(res, "survey", 3);
  ASSERT_TRUE(job.contains("id"));
  EXPECT_EQ(job["input"]["width"], 64);
  const std::string id = job["id"];
  FollowToEnd(client, id);
  const fs::path folder = dir_ / "data" / "jobs" / id / api::kImagesFolder;
  {
    std::lock_guard lock(ran_mutex_);
    EXPECT_EQ(ran_input_, folder);  // the engine maps the folder, with the photo budget
    EXPECT_EQ(ran_max_features_, kPhotoFolderMaxFeatures);
  }
  std::set<std::string> stored;
  for (const fs::directory_entry& e : fs::directory_iterator(folder)) stored.insert(e.path().filename().string());
  EXPECT_EQ(stored, (std::set<std::string>{"DJI_0001.png", "DJI_0002.png", "DJI_0003.png"}));
  EXPECT_TRUE(glam::testing::ReadFile(folder / "DJI_0001.png") == PngPhoto(2));  // "../../DJI_0001.png"
  EXPECT_FALSE(fs::exists(dir_ / "DJI_0001.png"));
  EXPECT_FALSE(fs::exists(dir_ / "data" / "DJI_0001.png"));
  // Restarting keeps the photos.
  res = client.Post("/api/v1/jobs/" + id + "/restart");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200) << res->body;
  FollowToEnd(client, id);
  EXPECT_TRUE(fs::exists(folder / "DJI_0003.png"));

  // Refused, and nothing left behind: not an image name, two photos under one name, a video
  // as well, telemetry (photos carry EXIF GPS), photos that do not decode.
  const std::size_t jobs_before = json::parse(client.Get("/api/v1/jobs")->body)["total"];
  ExpectError(client.Post("/api/v1/jobs", httplib::MultipartFormDataItems{
                                              {"images", PngPhoto(1), "a.png", "image/png"},
                                              {"images", "text", "notes.txt", "text/plain"}}),
              400, "bad_image", "not an image name");
  ExpectError(client.Post("/api/v1/jobs", httplib::MultipartFormDataItems{
                                              {"images", PngPhoto(1), "x/a.png", "image/png"},
                                              {"images", PngPhoto(2), "y/a.png", "image/png"}}),
              400, "bad_image", "duplicate names");
  ExpectError(client.Post("/api/v1/jobs", httplib::MultipartFormDataItems{
                                              {"images", PngPhoto(1), "a.png", "image/png"},
                                              {"video", glam::testing::ReadFile(video_), "c.avi", "video/x-msvideo"}}),
              400, "bad_upload", "video and images");
  ExpectError(client.Post("/api/v1/jobs", httplib::MultipartFormDataItems{
                                              {"images", PngPhoto(1), "a.png", "image/png"},
                                              {"telemetry", "1\n00:00:00,000 --> 00:00:01,000\n[latitude: 46.5] "
                                                            "[longitude: 7.5] [rel_alt: 5 abs_alt: 500]\n",
                                               "a.SRT", "application/x-subrip"}}),
              400, "bad_telemetry", "telemetry with photos");
  ExpectError(client.Post("/api/v1/jobs", httplib::MultipartFormDataItems{
                                              {"images", "not a JPEG at all", "a.jpg", "image/jpeg"}}),
              422, "unsupported_images", "undecodable photos");
  EXPECT_EQ(json::parse(client.Get("/api/v1/jobs")->body)["total"], jobs_before);
  EXPECT_TRUE(fs::is_empty(dir_ / "data" / "uploads"));
}

TEST_F(HttpApiTest, PhotoJobTakesItsFeatureBudgetFromTheOptions) {
  Start({}, "photo_features");
  auto client = Client();
  auto res = client.Post("/api/v1/jobs", httplib::MultipartFormDataItems{
                                             {"images", PngPhoto(1), "a.png", "image/png"},
                                             {"images", PngPhoto(2), "b.png", "image/png"},
                                             {"options", R"({"max_features": 3000})", "", "application/json"}});
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  const json job = json::parse(res->body);
  EXPECT_EQ(job["options"]["max_features"], 3000);
  FollowToEnd(client, job["id"]);
  std::lock_guard lock(ran_mutex_);
  EXPECT_EQ(ran_max_features_, 3000);  // not the photo default (kPhotoFolderMaxFeatures)
}

TEST_F(HttpApiTest, RawBodyUploadTakesOptionsFromQuery) {
  Start({}, "raw");
  auto client = Client();
  auto res = client.Post("/api/v1/jobs?name=raw%20clip&stride=2&fixed_k1=true&smooth_window_s=0.5&refine_focal=1&"
                         "max_features=3000&global_refinement_keyframes=0&rolling_shutter_ms=auto&detect_max_seconds=0.5&"
                         "filename=c.avi",
                         glam::testing::ReadFile(video_), "video/x-msvideo");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  const json job = json::parse(res->body);
  EXPECT_EQ(job["name"], "raw clip");
  EXPECT_EQ(job["options"]["stride"], 2);
  EXPECT_EQ(job["options"]["fixed_k1"], true);
  EXPECT_EQ(job["options"]["smooth_window_s"], 0.5);
  EXPECT_EQ(job["options"]["refine_focal"], true);
  EXPECT_EQ(job["options"]["max_features"], 3000);
  EXPECT_EQ(job["options"]["global_refinement_keyframes"], 0);
  EXPECT_EQ(job["options"]["rolling_shutter_ms"], "auto");
  EXPECT_EQ(job["options"]["detect_max_seconds"], 0.5);
  EXPECT_TRUE(fs::exists(dir_ / "data" / "jobs" / job["id"].get<std::string>() / "input.avi"));
  res = client.Post("/api/v1/jobs", {{"X-Glam-Options", R"({"keyframes_per_submap": 6})"}},
                    glam::testing::ReadFile(video_), "application/octet-stream");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  EXPECT_EQ(json::parse(res->body)["options"]["keyframes_per_submap"], 6);
}

TEST_F(HttpApiTest, StreamJobsAreOffByDefault) {
  Start({}, "streams_off");
  auto client = Client();
  ExpectError(client.Post("/api/v1/jobs", R"({"stream_url": "rtsp://cam/live"})", "application/json"), 403,
              "streams_disabled", "streams off");
}

TEST_F(HttpApiTest, StreamJobsFromJsonAndTheirErrors) {
  allow_streams_ = true;
  Start({}, "streams_on");
  auto client = Client();
  const auto post = [&](const std::string& body) { return client.Post("/api/v1/jobs", body, "application/json"); };
  ExpectError(post("{not json"), 400, "bad_request", "malformed JSON");
  ExpectError(post(R"(["rtsp://cam/live"])"), 400, "bad_request", "not an object");
  ExpectError(post(R"({"url": "rtsp://cam/live"})"), 400, "bad_request", "unknown field");
  ExpectError(post(R"({"options": {}})"), 400, "bad_request", "no stream_url");
  ExpectError(post(R"({"stream_url": 5})"), 400, "bad_request", "stream_url not a string");
  ExpectError(post(R"({"stream_url": "file:///etc/passwd"})"), 400, "bad_request", "a file URL");
  ExpectError(post(R"({"stream_url": "-"})"), 400, "bad_request", "standard input");
  ExpectError(post(R"({"stream_url": "rtsp://cam/live", "options": {"stride": 0}})"), 400, "", "bad options");
  ExpectError(post(R"({"stream_url": "rtsp://cam/)" + std::string(70000, 'x') + "\"}"), 413,
              "payload_too_large", "huge body");

  auto res = post(R"({"stream_url": "rtsp://user:pw@cam/live", "options": {"name": "drone 1"}})");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  const json job = json::parse(res->body);
  EXPECT_EQ(res->get_header_value("Location"), "/api/v1/jobs/" + job["id"].get<std::string>());
  EXPECT_EQ(job["name"], "drone 1");
  EXPECT_EQ(job["input"]["stream_url"], "rtsp://***@cam/live");
  // A file job cannot be finished, only canceled.
  const std::string file_job = CreateJob(client);
  ExpectError(client.Post("/api/v1/jobs/" + file_job + "/finish"), 409, "invalid_state", "finish a file job");
  ExpectError(client.Post("/api/v1/jobs/0123456789abcdef/finish"), 404, "not_found", "finish an unknown job");
}

TEST_F(HttpApiTest, BadRequestCorpusGetsDocumentedStatuses) {
  Start({}, "corpus");
  auto client = Client();
  const std::string video = glam::testing::ReadFile(video_);
  ExpectError(client.Post("/api/v1/jobs", "hello", "text/plain"), 415, "unsupported_media_type", "text/plain");
  ExpectError(client.Post("/api/v1/jobs", "", "video/mp4"), 400, "empty_body", "empty body");
  ExpectError(client.Post("/api/v1/jobs", std::string(4096, 'x'), "video/mp4"), 422, "unsupported_video", "garbage");
  ExpectError(client.Post("/api/v1/jobs", video.substr(0, 200), "video/x-msvideo"), 422, "unsupported_video",
              "truncated");
  ExpectError(client.Post("/api/v1/jobs", std::string(2 << 20, 'x'), "video/mp4"), 413, "payload_too_large",
              "oversized raw");
  ExpectError(client.Post("/api/v1/jobs",
                          httplib::MultipartFormDataItems{{"video", std::string(2 << 20, 'x'), "big.mp4", "video/mp4"}}),
              413, "payload_too_large", "oversized multipart");
  ExpectError(UploadMultipart(client, "{not json"), 400, "bad_request", "malformed options");
  ExpectError(UploadMultipart(client, R"({"stride": -3})"), 400, "bad_request", "bad stride");
  ExpectError(client.Post("/api/v1/jobs?stride=abc", video, "video/x-msvideo"), 400, "bad_request", "bad query");
  ExpectError(client.Post("/api/v1/jobs?fixed_k1=maybe", video, "video/x-msvideo"), 400, "bad_request",
              "bad boolean query");
  ExpectError(client.Post("/api/v1/jobs?refine_focal=yes", video, "video/x-msvideo"), 400, "bad_request",
              "bad boolean query (refine_focal)");
  ExpectError(client.Post("/api/v1/jobs?max_features=20", video, "video/x-msvideo"), 400, "bad_request",
              "too few features");
  ExpectError(client.Post("/api/v1/jobs?smooth_window_s=0.5s", video, "video/x-msvideo"), 400, "bad_request",
              "bad number query");
  ExpectError(client.Post("/api/v1/jobs", httplib::MultipartFormDataItems{{"other", "x", "", "text/plain"}}), 400,
              "missing_video", "no video field");
  ExpectError(client.Get("/api/v1/jobs/ffffffffffffffff"), 404, "not_found", "unknown id");
  ExpectError(client.Get("/api/v1/jobs/FFFFFFFFFFFFFFFF"), 400, "invalid_id", "upper-case id");
  ExpectError(client.Get("/api/v1/jobs/a.b"), 400, "invalid_id", "id with a dot");
  ExpectError(client.Post("/api/v1/jobs/ffffffffffffffff/cancel"), 404, "not_found", "cancel unknown");
  ExpectError(client.Delete("/api/v1/jobs/ffffffffffffffff"), 404, "not_found", "delete unknown");
  ExpectError(client.Get("/api/v1/jobs?limit=abc"), 400, "bad_request", "limit abc");
  ExpectError(client.Get("/api/v1/jobs?limit=0"), 400, "bad_request", "limit 0");
  ExpectError(client.Get("/api/v1/nothing"), 404, "not_found", "unknown route");

  // Actions not allowed in the current state.
  engine_.hold = true;
  const std::string id = CreateJob(client);
  WaitForHold();
  ExpectError(client.Post("/api/v1/jobs/" + id + "/restart"), 409, "invalid_state", "restart running");
  ExpectError(client.Get("/api/v1/jobs/" + id + "/trajectory.tum"), 409, "not_ready", "download running");
  ExpectError(client.Get("/api/v1/jobs/" + id + "/parts/1/trajectory.tum"), 409, "not_ready", "part running");
  ExpectError(client.Get("/api/v1/jobs/" + id + "/events", {{"Last-Event-ID", "abc"}}), 400, "bad_request",
              "bad Last-Event-ID");
  ExpectError(client.Get("/api/v1/jobs/" + id + "/tiles/abc.glb"), 400, "bad_request", "tile name");
  auto res = client.Post("/api/v1/jobs/" + id + "/cancel");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(json::parse(res->body)["state"], "canceled");
  ExpectError(client.Post("/api/v1/jobs/" + id + "/cancel"), 409, "invalid_state", "cancel canceled");

  res = client.Get("/api/v1/health");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_TRUE(json::parse(res->body)["ok"].get<bool>());
}

TEST_F(HttpApiTest, PathTraversalNeverReachesTheFileSystem) {
  Start({}, "traversal");
  std::ofstream(dir_ / "secret.txt") << "TOPSECRET-42";
  auto client = Client();
  const std::string id = CreateJob(client);
  FollowToEnd(client, id);
  for (const std::string& path : std::vector<std::string>{
           "/api/v1/jobs/..%2f..%2fetc/trajectory.tum", "/api/v1/jobs/..%2F..%2F..%2Fsecret.txt",
        "/api/v1/jobs/../../secret.txt", "/api/v1/jobs/" + id + "/..%2f..%2f..%2fsecret.txt",
        "/api/v1/jobs/" + id + "/tiles/..%2f..%2fglam.db", "/api/v1/jobs/" + id + "/tiles/..%2f1.glb",
        "/api/v1/jobs/%2e%2e/trajectory.tum", "/api/v1/jobs/" + id + "%2f..%2f..%2fglam.db",
        "/api/v1/jobs/" + id + "/parts/..%2f..%2f..%2f/trajectory.tum",
        "/api/v1/jobs/" + id + "/parts/%2e%2e/points.ply"}) {
    auto res = client.Get(path);
    ASSERT_TRUE(res) << path;
    EXPECT_TRUE(res->status == 400 || res->status == 404) << path << " -> " << res->status;
    EXPECT_EQ(res->body.find("TOPSECRET"), std::string::npos) << path;
    EXPECT_EQ(res->body.find("SQLite"), std::string::npos) << path;
  }
}

TEST_F(HttpApiTest, TokenIsRequiredExceptForHealthAndSpec) {
  HttpServerOptions options;
  options.token = "s3cret-token";
  Start(options, "token");
  auto anonymous = Client();
  ExpectError(anonymous.Get("/api/v1/jobs"), 401, "unauthorized", "no token");
  ExpectError(UploadMultipart(anonymous), 401, "unauthorized", "upload without token");
  ExpectError(anonymous.Get("/api/v1/metrics"), 401, "unauthorized", "metrics");
  auto wrong = Client();
  wrong.set_bearer_token_auth("s3cret-tokem");
  ExpectError(wrong.Get("/api/v1/jobs"), 401, "unauthorized", "wrong token");
  EXPECT_EQ(anonymous.Get("/api/v1/health")->status, 200);
  EXPECT_EQ(anonymous.Get("/api/v1/openapi.yaml")->status, 200);
  EXPECT_EQ(anonymous.Get("/api/v1/jobs?token=s3cret-token")->status, 200);  // EventSource style
  token_ = "s3cret-token";
  auto client = Client();
  EXPECT_EQ(client.Get("/api/v1/jobs")->status, 200);
  const std::string id = CreateJob(client);
  EXPECT_FALSE(id.empty());
  ExpectError(anonymous.Get("/api/v1/jobs/" + id + "/events"), 401, "unauthorized", "events");
}

TEST_F(HttpApiTest, LastEventIdReplaysExactlyTheMissedEvents) {
  Start({}, "replay");
  auto client = Client();
  const std::string id = CreateJob(client);
  const auto all = FollowToEnd(client, id);
  ASSERT_GE(all.size(), 4u);
  const std::int64_t resume_after = all[1].id;
  std::vector<std::int64_t> expected;
  for (const SseEvent& e : all) {
    // progress and preview: only the latest of them, while the job runs
    if (e.id > resume_after && e.type != "progress" && e.type != "preview") expected.push_back(e.id);
  }
  const auto replay = FollowToEnd(client, id, {{"Last-Event-ID", std::to_string(resume_after)}});
  std::vector<std::int64_t> got;
  for (const SseEvent& e : replay) got.push_back(e.id);
  EXPECT_EQ(got, expected);
  // Query-parameter form for clients that cannot set headers.
  const auto result = ReadSse(client, "/api/v1/jobs/" + id + "/events?lastEventId=" + std::to_string(resume_after),
                              {}, [](const SseEvent&) { return false; });
  EXPECT_EQ(result.events.size(), expected.size());
}

TEST_F(HttpApiTest, TwoUploadsAtOnceBothComplete) {
  Start({}, "parallel");
  std::string ids[2];
  std::thread uploads[2];
  for (int i = 0; i < 2; ++i) {
    uploads[i] = std::thread([&, i] {
      auto client = Client();
      ids[i] = CreateJob(client);
    });
  }
  for (auto& t : uploads) t.join();
  ASSERT_FALSE(ids[0].empty());
  ASSERT_FALSE(ids[1].empty());
  EXPECT_NE(ids[0], ids[1]);
  auto client = Client();
  for (const std::string& id : ids) {
    FollowToEnd(client, id);
    EXPECT_EQ(json::parse(client.Get("/api/v1/jobs/" + id)->body)["state"], "completed");
  }
}

TEST_F(HttpApiTest, CancelRestartDeleteOverHttp) {
  Start({}, "lifecycle");
  auto client = Client();
  engine_.hold = true;
  const std::string id = CreateJob(client);
  WaitForHold();
  auto res = client.Post("/api/v1/jobs/" + id + "/cancel");
  ASSERT_TRUE(res);
  EXPECT_EQ(json::parse(res->body)["state"], "canceled");
  engine_.hold = false;
  res = client.Post("/api/v1/jobs/" + id + "/restart");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(json::parse(res->body)["state"], "queued");
  FollowToEnd(client, id, {{"Last-Event-ID", json::parse(res->body)["id"].is_string() ? "0" : "0"}});
  EXPECT_EQ(json::parse(client.Get("/api/v1/jobs/" + id)->body)["state"], "completed");
  res = client.Delete("/api/v1/jobs/" + id);
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 204);
  EXPECT_EQ(client.Get("/api/v1/jobs/" + id)->status, 404);
  EXPECT_FALSE(fs::exists(dir_ / "data" / "jobs" / id));
}

TEST_F(HttpApiTest, EventStreamsAreBounded) {
  HttpServerOptions options;
  options.max_sse_clients = 1;
  options.http_threads = 8;
  Start(options, "sse_limit");
  engine_.hold = true;
  auto client = Client();
  const std::string id = CreateJob(client);
  WaitForHold();
  std::atomic<bool> first_open{false};
  std::thread first([&] {
    auto c = Client();
    ReadSse(c, "/api/v1/jobs/" + id + "/events", {}, [&](const SseEvent&) {
      first_open = true;
      return false;
    }, 20s);
  });
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!first_open && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(5ms);
  ASSERT_TRUE(first_open);
  ExpectError(client.Get("/api/v1/jobs/" + id + "/events"), 503, "too_many_streams", "second stream");
  engine_.hold = false;  // the job completes, the first stream ends
  first.join();
}

TEST_F(HttpApiTest, CorsHeadersOnlyWhenConfigured) {
  HttpServerOptions options;
  options.cors_origin = "https://viewer.example";
  Start(options, "cors");
  auto client = Client();
  auto res = client.Get("/api/v1/jobs");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->get_header_value("Access-Control-Allow-Origin"), "https://viewer.example");
  res = client.Options("/api/v1/jobs", {{"Origin", "https://viewer.example"},
                                        {"Access-Control-Request-Method", "POST"}});
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 204);
  EXPECT_NE(res->get_header_value("Access-Control-Allow-Headers").find("Authorization"), std::string::npos);
}

TEST_F(HttpApiTest, NoCorsHeadersByDefault) {
  Start({}, "nocors");
  auto client = Client();
  auto res = client.Get("/api/v1/jobs");
  ASSERT_TRUE(res);
  EXPECT_FALSE(res->has_header("Access-Control-Allow-Origin"));
}

// A full disk is simulated with the process file-size limit: writes past it fail (EFBIG),
// exactly like ENOSPC for the upload code.
TEST_F(HttpApiTest, FullDiskDuringUploadIs507AndLeavesNoPartialFile) {
  Start({}, "disk_full");
  auto client = Client();
  ASSERT_EQ(client.Get("/api/v1/health")->status, 200);  // store opened and written before the limit
  auto res = WithFileSizeLimit(256 * 1024,
                               [&] { return client.Post("/api/v1/jobs", std::string(600 * 1024, 'x'), "video/mp4"); });
  ExpectError(res, 507, "insufficient_storage", "disk full");
  EXPECT_TRUE(fs::is_empty(dir_ / "data" / "uploads"));
  auto again = Client();
  EXPECT_EQ(again.Get("/api/v1/health")->status, 200);
}

TEST_F(HttpApiTest, OpenApiDocumentsEveryRoute) {
  Start({}, "openapi");
  auto client = Client();
  auto res = client.Get("/api/v1/openapi.yaml");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);
  // Minimal YAML reading: path keys are indented 2 spaces under `paths:`, operations 4.
  std::set<std::pair<std::string, std::string>> documented;
  std::istringstream in(res->body);
  std::string line;
  std::string current_path;
  bool in_paths = false;
  const std::regex path_key(R"(^  (/[^:]+):\s*$)");
  const std::regex method_key(R"(^    (get|post|put|delete|patch):\s*$)");
  std::smatch m;
  while (std::getline(in, line)) {
    if (line.rfind("paths:", 0) == 0) {
      in_paths = true;
    } else if (!line.empty() && line[0] != ' ' && line[0] != '#') {
      in_paths = false;
    } else if (in_paths && std::regex_match(line, m, path_key)) {
      current_path = m[1];
    } else if (in_paths && std::regex_match(line, m, method_key)) {
      std::string method = m[1];
      for (char& c : method) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      documented.insert({method, "/api/v1" + current_path});
    }
  }
  std::set<std::pair<std::string, std::string>> registered;
  for (const RouteInfo& route : HttpServer::Routes()) registered.insert({route.method, route.path});
  for (const auto& route : registered) {
    EXPECT_EQ(documented.count(route), 1u) << route.first << " " << route.second << " is not in openapi.yaml";
  }
  for (const auto& doc : documented) {
    EXPECT_EQ(registered.count(doc), 1u) << doc.first << " " << doc.second << " is documented but not served";
  }
  EXPECT_GE(registered.size(), 17u);
}

TEST_F(HttpApiTest, HealthAndMetricsReportJobsAndRequests) {
  Start({}, "metrics");
  auto client = Client();
  const std::string id = CreateJob(client);
  FollowToEnd(client, id);
  client.Get("/api/v1/jobs/" + id);
  auto res = client.Get("/api/v1/health");
  ASSERT_TRUE(res);
  const json health = json::parse(res->body);
  EXPECT_TRUE(health["ok"].get<bool>());
  EXPECT_EQ(health["jobs"]["completed"], 1);
  EXPECT_GT(health["disk_free_bytes"].get<double>(), 0);
  res = client.Get("/api/v1/metrics");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  const std::string& text = res->body;
  EXPECT_NE(text.find("glam_jobs{state=\"completed\"} 1\n"), std::string::npos) << text;
  EXPECT_NE(text.find("glam_frames_processed_total 30\n"), std::string::npos) << text;
  EXPECT_NE(text.find("glam_http_requests_total{route=\"/api/v1/jobs/{id}\",method=\"GET\",code=\"200\"} 1\n"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("glam_http_request_duration_seconds_count{route=\"/api/v1/jobs\"}"), std::string::npos);
}

}  // namespace
}  // namespace glam::server
