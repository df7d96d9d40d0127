// Resumable uploads over real HTTP (/api/v1/uploads, server/http_resumable_upload.cc): a video
// sent in chunks becomes a job with exactly its bytes; a PATCH whose connection breaks keeps
// what arrived, and so does a server restart; every refusal is a documented JSON error that
// leaves the upload usable. A photo survey sent as an image set, one photo per PUT, becomes a
// photo job; a photo whose request broke is not kept, the ones before it are.
#include <unistd.h>


#include <chrono>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "api/job_service.h"
#include "server/http_server.h"
#include "tests/server/http_api_fixture.h"

namespace glam::server {
namespace {

class ResumableUploadTest : public HttpApiTest {
 protected:
  // POST /api/v1/uploads; the new upload's id.
  std::string Open(httplib::Client& client, std::int64_t size, const std::string& filename) {
    auto res = client.Post("/api/v1/uploads", json{{"size", size}, {"filename", filename}}.dump(), "application/json");
    EXPECT_TRUE(res);
    if (!res) return "";
    EXPECT_EQ(res->status, 201) << res->body;
    const json upload = json::parse(res->body);
    EXPECT_EQ(res->get_header_value("Location"), "/api/v1/uploads/" + upload["id"].get<std::string>());
    EXPECT_EQ(upload["offset"], 0);
    EXPECT_EQ(upload["size"], size);
    return upload["id"];
  }

  httplib::Result Patch(httplib::Client& client, const std::string& id, std::int64_t offset, const std::string& bytes,
                        const std::string& type = "application/offset+octet-stream") {
    return client.Patch("/api/v1/uploads/" + id, {{"Upload-Offset", std::to_string(offset)}}, bytes, type.c_str());
  }

  // Sends `bytes` from `offset` in chunks of `chunk`, checking each answer.
  void SendFrom(httplib::Client& client, const std::string& id, const std::string& bytes, std::size_t offset,
                std::size_t chunk) {
    for (std::size_t at = offset; at < bytes.size(); at += chunk) {
      const std::string part = bytes.substr(at, chunk);
      auto res = Patch(client, id, static_cast<std::int64_t>(at), part);
      ASSERT_TRUE(res);
      ASSERT_EQ(res->status, 200) << res->body;
      const std::int64_t now = static_cast<std::int64_t>(at + part.size());
      EXPECT_EQ(res->get_header_value("Upload-Offset"), std::to_string(now));
      const json upload = json::parse(res->body);
      EXPECT_EQ(upload["offset"], now);
      EXPECT_EQ(upload["complete"], now == upload["size"].get<std::int64_t>());
    }
  }

  std::int64_t OffsetOf(httplib::Client& client, const std::string& id) {
    auto res = client.Get("/api/v1/uploads/" + id);
    EXPECT_TRUE(res);
    if (!res || res->status != 200) return -1;
    EXPECT_EQ(res->get_header_value("Upload-Offset"), std::to_string(json::parse(res->body)["offset"].get<std::int64_t>()));
    return json::parse(res->body)["offset"];
  }

  httplib::Result CreateJobFrom(httplib::Client& client, const json& request) {
    return client.Post("/api/v1/jobs", request.dump(), "application/json");
  }
};

TEST_F(ResumableUploadTest, AVideoSentInChunksBecomesAJobWithExactlyItsBytes) {
  Start({}, "resumable_chunks");
  auto client = Client();
  const std::string video = glam::testing::ReadFile(video_);
  ASSERT_GT(video.size(), 3000u);
  const std::string id = Open(client, static_cast<std::int64_t>(video.size()), "flights/DJI_0042.avi");
  SendFrom(client, id, video, 0, 1000);
  auto res = client.Get("/api/v1/uploads/" + id);
  ASSERT_TRUE(res);
  const json upload = json::parse(res->body);
  EXPECT_EQ(upload["complete"], true);
  EXPECT_EQ(upload["filename"], "DJI_0042.avi");

  res = CreateJobFrom(client, {{"upload_id", id}, {"options", {{"name", "chunked"}}}});
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  const json job = json::parse(res->body);
  EXPECT_EQ(job["name"], "chunked");
  EXPECT_EQ(job["input"]["filename"], "DJI_0042.avi");
  EXPECT_EQ(job["input"]["size_bytes"], video.size());
  const auto events = FollowToEnd(client, job["id"]);
  ASSERT_FALSE(events.empty());
  EXPECT_EQ(events.back().data["state"], "completed");
  {
    std::lock_guard lock(ran_mutex_);
    EXPECT_EQ(ran_input_.extension(), ".avi");
    EXPECT_EQ(glam::testing::ReadFile(ran_input_), video);
  }
  // The upload was consumed by the job.
  ExpectError(client.Get("/api/v1/uploads/" + id), 404, "not_found", "consumed upload");
  ExpectError(CreateJobFrom(client, {{"upload_id", id}}), 404, "not_found", "second job from one upload");
  EXPECT_TRUE(fs::is_empty(dir_ / "data" / "resumable"));
}

TEST_F(ResumableUploadTest, ABrokenConnectionAndARestartKeepTheBytesThatArrived) {
  Start({}, "resumable_broken");
  auto client = Client();
  const std::string video = glam::testing::ReadFile(video_);
  const std::string id = Open(client, static_cast<std::int64_t>(video.size()), "clip.avi");
  SendFrom(client, id, video.substr(0, 1000), 0, 1000);
  // 700 of 2000 bytes arrive, then the link drops.
  ::close(StartPatch(port_, id, 1000, video.substr(1000, 700), 2000));
  // While the server reads the dying connection, a PATCH is refused as busy (never
  // interleaved); before and after, as an offset mismatch (offset 0 is wrong either way), whose
  // offset is 1000 until the server has taken the request up and 1700 once it has seen it end.
  std::int64_t offset = -1;
  for (auto deadline = std::chrono::steady_clock::now() + 10s; std::chrono::steady_clock::now() < deadline;) {
    auto probe = Patch(client, id, 0, "x");
    ASSERT_TRUE(probe);
    ASSERT_EQ(probe->status, 409) << probe->body;
    const std::string code = json::parse(probe->body)["error"]["code"];
    ASSERT_TRUE(code == "upload_busy" || code == "offset_mismatch") << code;
    if (code == "offset_mismatch") {
      offset = std::stoll(probe->get_header_value("Upload-Offset"));
      ASSERT_TRUE(offset == 1000 || offset == 1700) << offset;
      if (offset == 1700) break;
    }
    std::this_thread::sleep_for(20ms);
  }
  ASSERT_EQ(offset, 1700);
  ASSERT_EQ(OffsetOf(client, id), 1700);

  // The server restarts: the upload is still there, at the same offset.
  Stop();
  Launch();
  auto after = Client();
  ASSERT_EQ(OffsetOf(after, id), 1700);
  // A client that resends from its own last confirmed offset is told where to go on.
  auto stale = Patch(after, id, 1000, video.substr(1000, 100));
  ExpectError(stale, 409, "offset_mismatch", "resend from an old offset");
  EXPECT_EQ(stale->get_header_value("Upload-Offset"), "1700");
  ExpectError(CreateJobFrom(after, {{"upload_id", id}}), 409, "upload_incomplete", "job from a partial upload");
  SendFrom(after, id, video, 1700, 1500);

  auto res = CreateJobFrom(after, {{"upload_id", id}});
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  EXPECT_EQ(FollowToEnd(after, json::parse(res->body)["id"]).back().data["state"], "completed");
  std::lock_guard lock(ran_mutex_);
  EXPECT_EQ(glam::testing::ReadFile(ran_input_), video);
}

TEST_F(ResumableUploadTest, RefusalsAreDocumentedErrorsAndLeaveTheUploadUsable) {
  HttpServerOptions options;
  options.max_open_uploads = 3;
  Start(options, "resumable_errors");
  auto client = Client();
  auto open = [&](const std::string& body) { return client.Post("/api/v1/uploads", body, "application/json"); };
  ExpectError(open("{"), 400, "bad_request", "not JSON");
  ExpectError(open(R"({"filename": "a.mp4"})"), 400, "bad_request", "no size");
  ExpectError(open(R"({"size": "12"})"), 400, "bad_request", "size not a number");
  ExpectError(open(R"({"size": 0})"), 400, "bad_request", "empty");
  ExpectError(open(R"({"size": 12, "md5": "x"})"), 400, "bad_request", "unknown field");
  ExpectError(open(R"({"size": 2097152})"), 413, "payload_too_large", "over --max-upload-mb (1 MiB here)");

  const std::string id = Open(client, 10, "a.mp4");
  ExpectError(client.Patch("/api/v1/uploads/" + id, "0123", "application/offset+octet-stream"), 400, "bad_request",
              "no Upload-Offset");
  ExpectError(client.Patch("/api/v1/uploads/" + id, {{"Upload-Offset", "-1"}}, "0123",
                           "application/offset+octet-stream"),
              400, "bad_request", "negative offset");
  ExpectError(Patch(client, id, 0, "0123", "text/plain"), 415, "unsupported_media_type", "text body");
  ExpectError(Patch(client, id, 0, "0123456789ab"), 413, "payload_too_large", "past the size");
  ExpectError(Patch(client, id, 3, "0123"), 409, "offset_mismatch", "gap");
  ExpectError(Patch(client, "0123456789abcdef", 0, "0123"), 404, "not_found", "unknown upload");
  ExpectError(Patch(client, "ABC", 0, "0123"), 400, "invalid_id", "malformed id");
  ExpectError(client.Get("/api/v1/uploads/.."), 400, "invalid_id", "path trick");
  EXPECT_EQ(OffsetOf(client, id), 0);  // nothing refused was stored

  // Job requests that cannot be served keep the upload.
  ExpectError(CreateJobFrom(client, {{"upload_id", id}}), 409, "upload_incomplete", "incomplete");
  const std::string video_id = Open(client, static_cast<std::int64_t>(glam::testing::ReadFile(video_).size()), "v.avi");
  SendFrom(client, video_id, glam::testing::ReadFile(video_), 0, 4096);
  ExpectError(CreateJobFrom(client, {{"upload_id", video_id}, {"stream_url", "rtsp://cam/live"}}), 400, "bad_request",
              "upload and stream");
  ExpectError(CreateJobFrom(client, {{"upload_id", video_id}, {"options", {{"stride", 0}}}}), 400, "",
              "bad options");
  ExpectError(CreateJobFrom(client, {{"upload_id", 5}}), 400, "bad_request", "id not a string");
  ExpectError(CreateJobFrom(client, {{"upload_id", video_id}, {"telemetry_upload_id", "0123456789abcdef"}}), 404,
              "not_found", "unknown telemetry upload");
  const std::string srt_id = Open(client, 9, "DJI_0042.SRT");
  SendFrom(client, srt_id, "no GPS.\n\n", 0, 100);
  ExpectError(CreateJobFrom(client, {{"upload_id", video_id}, {"telemetry_upload_id", srt_id}}), 400, "bad_telemetry",
              "telemetry without positions");
  EXPECT_EQ(OffsetOf(client, video_id), static_cast<std::int64_t>(glam::testing::ReadFile(video_).size()));
  ExpectError(open(R"({"size": 5})"), 503, "too_many_uploads", "over --max-open-uploads");
  auto metrics = client.Get("/api/v1/metrics");
  ASSERT_TRUE(metrics);
  EXPECT_NE(metrics->body.find("glam_resumable_uploads_open 3\n"), std::string::npos) << metrics->body;

  ASSERT_EQ(client.Delete("/api/v1/uploads/" + srt_id)->status, 204);
  ExpectError(client.Get("/api/v1/uploads/" + srt_id), 404, "not_found", "deleted upload");
  auto res = CreateJobFrom(client, {{"upload_id", video_id}});
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 201) << res->body;
}

// A body longer than what is left of the declared size: with a Content-Length it is refused
// before any byte is stored; sent chunked (no length known up front) the bytes up to the size
// are kept. A complete upload that is no video makes no job and is gone.
TEST_F(ResumableUploadTest, TooManyBytesAndACompleteUploadThatIsNoVideo) {
  Start({}, "resumable_not_video");
  auto client = Client();
  const std::string id = Open(client, 10, "a.mp4");
  auto res = Patch(client, id, 0, "not a video");
  ExpectError(res, 413, "payload_too_large", "one byte too many, declared");
  EXPECT_EQ(res->get_header_value("Upload-Offset"), "0");
  EXPECT_EQ(OffsetOf(client, id), 0);

  const std::string body = "not a video";
  res = client.Patch(
      "/api/v1/uploads/" + id, {{"Upload-Offset", "0"}},
      [&](std::size_t, httplib::DataSink& sink) {
        sink.write(body.data(), body.size());
        sink.done();
        return true;
      },
      "application/offset+octet-stream");
  ExpectError(res, 413, "payload_too_large", "one byte too many, chunked");
  EXPECT_EQ(res->get_header_value("Upload-Offset"), "10");
  auto after = Client();
  EXPECT_EQ(OffsetOf(after, id), 10);
  ExpectError(Patch(after, id, 10, "x"), 409, "upload_complete", "nothing left");
  ExpectError(CreateJobFrom(after, {{"upload_id", id}}), 422, "unsupported_video", "not a video");
  ExpectError(after.Get("/api/v1/uploads/" + id), 404, "not_found", "consumed by the refused job");
  EXPECT_TRUE(fs::is_empty(dir_ / "data" / "uploads"));
  EXPECT_TRUE(fs::is_empty(dir_ / "data" / "resumable"));
}

// A disk that fills during a PATCH (here: the process's file-size limit) is a 507; the bytes
// that were stored stay, the offset says how many, and the rest goes on once there is room.
TEST_F(ResumableUploadTest, AFullDiskKeepsWhatWasStored) {
  Start({}, "resumable_disk_full");
  auto client = Client();
  const std::string bytes(600 * 1024, 'x');
  const std::string id = Open(client, static_cast<std::int64_t>(bytes.size()), "a.mp4");
  auto res = WithFileSizeLimit(256 * 1024, [&] { return Patch(client, id, 0, bytes); });
  ExpectError(res, 507, "insufficient_storage", "disk full mid-body");
  auto again = Client();
  const std::int64_t kept = OffsetOf(again, id);
  EXPECT_GT(kept, 0);
  EXPECT_LE(kept, 256 * 1024);
  SendFrom(again, id, bytes, static_cast<std::size_t>(kept), 100 * 1024);
  EXPECT_EQ(OffsetOf(again, id), static_cast<std::int64_t>(bytes.size()));
}

// An abandoned upload is removed once it expires while the server runs, even when nobody
// opens another (before, the sweep ran at start and on POST /uploads only, so a multi-GB
// abandoned upload held its disk until then).
TEST_F(ResumableUploadTest, AnAbandonedUploadIsRemovedWhileTheServerRuns) {
  HttpServerOptions options;
  options.upload_sweep_interval = 50ms;
  Start(options, "resumable_sweep");
  auto client = Client();
  const std::string kept = Open(client, 10, "kept.mp4");
  const std::string abandoned = Open(client, 10, "abandoned.mp4");
  SendFrom(client, abandoned, "01234", 0, 5);
  // Its last byte arrived 25 hours ago (the expiry is 24 h).
  fs::last_write_time(dir_ / "data" / "resumable" / (abandoned + ".data"), fs::file_time_type::clock::now() - 25h);
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (fs::exists(dir_ / "data" / "resumable" / (abandoned + ".data")) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(20ms);
  }
  ExpectError(client.Get("/api/v1/uploads/" + abandoned), 404, "not_found", "expired while the server ran");
  EXPECT_FALSE(fs::exists(dir_ / "data" / "resumable" / (abandoned + ".json")));
  EXPECT_EQ(OffsetOf(client, kept), 0);  // the fresh one stays
}

// PUT /api/v1/uploads/{id}/images/{name} of `bytes`; the answer.
httplib::Result PutImage(httplib::Client& client, const std::string& id, const std::string& name,
                         const std::string& bytes, const char* type = "image/png") {
  return client.Put("/api/v1/uploads/" + id + "/images/" + name, bytes, type);
}

TEST_F(ResumableUploadTest, APhotoSurveySentAsAnImageSetBecomesAPhotoJob) {
  Start({}, "resumable_images");
  auto client = Client();
  const std::vector<std::string> photos = {PngPhoto(1), PngPhoto(2), PngPhoto(3)};
  const std::int64_t total = static_cast<std::int64_t>(photos[0].size() + photos[1].size() + photos[2].size());
  auto res = client.Post("/api/v1/uploads", json{{"kind", "images"}, {"size", total}}.dump(), "application/json");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 201) << res->body;
  const std::string id = json::parse(res->body)["id"];
  EXPECT_EQ(json::parse(res->body)["kind"], "images");
  EXPECT_EQ(json::parse(res->body)["images"], json::array());

  res = PutImage(client, id, "DJI_0001.png", photos[0]);
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;
  EXPECT_EQ(json::parse(res->body)["offset"], photos[0].size());
  EXPECT_EQ(json::parse(res->body)["image_count"], 1);
  EXPECT_FALSE(json::parse(res->body).contains("images"));  // the list is GET's
  // The link drops inside the second photo: nothing of it is kept, the first stays.
  ::close(StartRequest(port_, "PUT /api/v1/uploads/" + id + "/images/DJI_0002.png HTTP/1.1\r\nContent-Type: image/png\r\n",
                       photos[1].substr(0, 100), photos[1].size()));
  // ... and the server restarts.
  Stop();
  Launch();
  auto after = Client();
  json set;
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  do {  // the broken request may still be inside the old server when it stopped
    res = after.Get("/api/v1/uploads/" + id);
    ASSERT_TRUE(res);
    set = json::parse(res->body);
    if (set["images"].size() != 1) std::this_thread::sleep_for(20ms);
  } while (set["images"].size() != 1 && std::chrono::steady_clock::now() < deadline);
  ASSERT_EQ(set["images"].size(), 1u) << res->body;
  EXPECT_EQ(set["images"][0]["name"], "DJI_0001.png");
  EXPECT_EQ(set["offset"], photos[0].size());
  EXPECT_EQ(set["complete"], false);

  // Refusals, none of which stores anything.
  ExpectError(PutImage(after, id, "notes.txt", "text", "application/octet-stream"), 400, "bad_image", "not an image name");
  ExpectError(PutImage(after, id, "DJI%200002.png", photos[1]), 400, "bad_image", "a name to clean (a space)");
  ExpectError(PutImage(after, id, "DJI_0002.png", photos[1], "text/plain"), 415, "unsupported_media_type", "text");
  ExpectError(PutImage(after, id, "big.png", std::string(static_cast<std::size_t>(total), 'x')), 413,
              "payload_too_large", "past the declared size");
  ExpectError(after.Patch("/api/v1/uploads/" + id, {{"Upload-Offset", "0"}}, "x", "application/offset+octet-stream"),
              409, "wrong_kind", "a byte range of an image set");
  ExpectError(CreateJobFrom(after, {{"upload_id", id}}), 409, "upload_incomplete", "two photos missing");
  const std::string& second = photos[1];
  ExpectError(after.Put(
                  "/api/v1/uploads/" + id + "/images/DJI_0002.png",
                  [&](std::size_t, httplib::DataSink& sink) {
                    sink.write(second.data(), second.size());
                    sink.done();
                    return true;
                  },
                  "image/png"),
              411, "length_required", "a photo sent chunked");
  EXPECT_EQ(json::parse(after.Get("/api/v1/uploads/" + id)->body)["image_count"], 1);

  for (std::size_t i = 1; i < photos.size(); ++i) {
    res = PutImage(after, id, "DJI_000" + std::to_string(i + 1) + ".png", photos[i]);
    ASSERT_TRUE(res);
    ASSERT_EQ(res->status, 200) << res->body;
  }
  set = json::parse(after.Get("/api/v1/uploads/" + id)->body);
  EXPECT_EQ(set["complete"], true);
  const std::string srt_id = Open(after, 5, "a.SRT");
  SendFrom(after, srt_id, "12345", 0, 5);
  ExpectError(CreateJobFrom(after, {{"upload_id", id}, {"telemetry_upload_id", srt_id}}), 400, "bad_telemetry",
              "telemetry with photos");
  ExpectError(CreateJobFrom(after, {{"upload_id", srt_id}, {"telemetry_upload_id", id}}), 409, "wrong_kind",
              "an image set as telemetry");

  const json job = CreatedPhotoJob(CreateJobFrom(after, {{"upload_id", id}, {"options", {{"name", "survey"}}}}),
                                   "survey", 3);
  ASSERT_TRUE(job.contains("id"));
  FollowToEnd(after, job["id"]);
  const fs::path folder = dir_ / "data" / "jobs" / job["id"].get<std::string>() / api::kImagesFolder;
  {
    std::lock_guard lock(ran_mutex_);
    EXPECT_EQ(ran_input_, folder);  // mapped as a photo folder
  }
  for (std::size_t i = 0; i < photos.size(); ++i) {
    EXPECT_TRUE(glam::testing::ReadFile(folder / ("DJI_000" + std::to_string(i + 1) + ".png")) == photos[i]) << i;
  }
  ExpectError(after.Get("/api/v1/uploads/" + id), 404, "not_found", "consumed by the job");
}

}  // namespace
}  // namespace glam::server
