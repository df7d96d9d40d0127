// `glam upload`'s client (server/upload_client.h) against the real HTTP server with a fake
// engine: a file in chunks becomes a job whose results download; a chunk refused for a passing
// reason (the server's upload slots are full) is retried until it goes through; an upload is
// continued from the bytes the server has; a refusal is not retried; an unreachable server and
// a file that shrinks while it is sent are environment errors. Photos go as an image set, continued with the photos the set lacks.
#include <unistd.h>

#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "engine/core/error.h"
#include "server/upload_client.h"
#include "tests/server/http_api_fixture.h"

namespace glam::server {
namespace {

using api::ApiError;
using cli::UploadClient;
using cli::UploadClientOptions;
using cli::UploadProgress;

class UploadClientTest : public HttpApiTest {
 protected:
  UploadClientOptions ClientOptions() const {
    UploadClientOptions o;
    o.server = "http://127.0.0.1:" + std::to_string(port_);
    o.chunk_bytes = 4096;
    o.first_backoff = 20ms;
    o.max_backoff = 100ms;
    o.request_timeout = 10s;
    return o;
  }
};

TEST_F(UploadClientTest, AFileInChunksBecomesAJobWhoseResultsDownload) {
  Start({}, "client_job");
  UploadClient client(ClientOptions());
  std::vector<std::int64_t> offsets;
  const std::string upload_id = client.UploadFile(video_, "", [&](const UploadProgress& p) {
    EXPECT_TRUE(p.retry.empty()) << p.retry;
    offsets.push_back(p.offset);
  });
  const std::string video = glam::testing::ReadFile(video_);
  ASSERT_FALSE(offsets.empty());
  EXPECT_EQ(offsets.front(), 0);
  EXPECT_EQ(offsets.back(), static_cast<std::int64_t>(video.size()));
  EXPECT_EQ(offsets.size(), 1 + (video.size() + 4095) / 4096);  // the start, then one per chunk

  const json job = client.CreateJob(upload_id, "", {{"name", "from the client"}});
  EXPECT_EQ(job["name"], "from the client");
  auto http = Client();
  EXPECT_EQ(FollowToEnd(http, job["id"]).back().data["state"], "completed");
  EXPECT_EQ(client.GetJob(job["id"])["state"], "completed");
  {
    std::lock_guard lock(ran_mutex_);
    EXPECT_EQ(glam::testing::ReadFile(ran_input_), video);
  }
  client.Download(job["id"], "trajectory.tum", dir_ / "trajectory.tum");
  EXPECT_EQ(glam::testing::ReadFile(dir_ / "trajectory.tum"), kTrajectory);
  // A refused download leaves no file behind and says why.
  try {
    client.Download(job["id"], "parts/1/points.ply", dir_ / "part.ply");
    ADD_FAILURE() << "no part 1, yet downloaded";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.status(), 404);
    EXPECT_EQ(e.code(), "not_found");
  }
  EXPECT_FALSE(fs::exists(dir_ / "part.ply"));
  EXPECT_FALSE(fs::exists(dir_ / "part.ply.part"));
  EXPECT_EQ(client.UrlOf("/?job=x"), "http://127.0.0.1:" + std::to_string(port_) + "/?job=x");
}

TEST_F(UploadClientTest, AChunkRefusedForAPassingReasonIsRetried) {
  HttpServerOptions options;
  options.max_concurrent_uploads = 1;
  Start(options, "client_retry");
  auto http = Client();
  // Another upload's PATCH holds the only upload slot, its body half sent.
  auto other = http.Post("/api/v1/uploads", R"({"size": 100})", "application/json");
  ASSERT_TRUE(other);
  ASSERT_EQ(other->status, 201);
  int holder = StartPatch(port_, json::parse(other->body)["id"], 0, std::string(10, 'x'), 100);

  UploadClient client(ClientOptions());
  std::vector<std::string> retries;
  const std::string upload_id = client.UploadFile(video_, "", [&](const UploadProgress& p) {
    if (p.retry.empty()) return;
    retries.push_back(p.retry);
    if (holder >= 0) {  // the other client's link drops: the slot frees
      ::close(holder);
      holder = -1;
    }
  });
  if (holder >= 0) ::close(holder);
  ASSERT_FALSE(retries.empty());
  EXPECT_NE(retries.front().find("too_many_uploads"), std::string::npos) << retries.front();
  EXPECT_EQ(client.CreateJob(upload_id, "", json::object())["input"]["size_bytes"],
            glam::testing::ReadFile(video_).size());
}

TEST_F(UploadClientTest, AnUploadIsContinuedFromTheBytesTheServerHas) {
  Start({}, "client_continue");
  auto http = Client();
  const std::string video = glam::testing::ReadFile(video_);
  auto res = http.Post("/api/v1/uploads", json{{"size", video.size()}}.dump(), "application/json");
  ASSERT_TRUE(res);
  const std::string id = json::parse(res->body)["id"];
  res = http.Patch("/api/v1/uploads/" + id, {{"Upload-Offset", "0"}}, video.substr(0, 5000),
                   "application/offset+octet-stream");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200);

  UploadClient client(ClientOptions());
  std::int64_t first = -1;
  EXPECT_EQ(client.UploadFile(video_, id, [&](const UploadProgress& p) {
    if (first < 0) first = p.offset;
  }),
            id);
  EXPECT_EQ(first, 5000);  // nothing sent twice
  const json job = client.CreateJob(id, "", json::object());
  EXPECT_EQ(FollowToEnd(http, job["id"]).back().data["state"], "completed");
  {
    std::lock_guard lock(ran_mutex_);
    EXPECT_EQ(glam::testing::ReadFile(ran_input_), video);
  }
  // Another file under that id: refused before a byte is sent.
  std::ofstream(dir_ / "other.mp4") << "short";
  EXPECT_THROW(client.UploadFile(dir_ / "other.mp4", id, {}), ApiError);  // consumed by the job: 404
}

TEST_F(UploadClientTest, PhotosGoAsAnImageSetContinuedWithThePhotosItLacks) {
  Start({}, "client_photos");
  const fs::path folder = dir_ / "survey";
  fs::create_directories(folder);
  std::vector<fs::path> photos;
  for (int i = 1; i <= 3; ++i) {
    photos.push_back(folder / ("DJI 000" + std::to_string(i) + ".png"));  // sent as DJI_000i.png
    std::ofstream(photos.back(), std::ios::binary) << PngPhoto(i);
  }
  std::int64_t total = 0;
  for (const fs::path& p : photos) total += static_cast<std::int64_t>(fs::file_size(p));
  // A set that already holds the first photo (an earlier run that broke off).
  auto http = Client();
  auto res = http.Post("/api/v1/uploads", json{{"kind", "images"}, {"size", total}}.dump(), "application/json");
  ASSERT_TRUE(res);
  const std::string id = json::parse(res->body)["id"];
  res = http.Put("/api/v1/uploads/" + id + "/images/DJI_0001.png", PngPhoto(1), "image/png");
  ASSERT_TRUE(res);
  ASSERT_EQ(res->status, 200) << res->body;

  UploadClient client(ClientOptions());
  std::vector<std::int64_t> offsets;
  EXPECT_EQ(client.UploadImages(photos, "survey", id, [&](const UploadProgress& p) { offsets.push_back(p.offset); }),
            id);
  const auto first_size = static_cast<std::int64_t>(fs::file_size(photos[0]));
  // Started at the photo the server had, then one step per photo sent (not the first again).
  ASSERT_EQ(offsets.size(), 3u);
  EXPECT_EQ(offsets.front(), first_size);
  EXPECT_EQ(offsets.back(), total);
  const json job = client.CreateJob(id, "", json::object());
  EXPECT_EQ(job["input"]["images"], 3);
  EXPECT_EQ(FollowToEnd(http, job["id"]).back().data["state"], "completed");
  {
    std::lock_guard lock(ran_mutex_);
    EXPECT_TRUE(glam::testing::ReadFile(ran_input_ / "DJI_0003.png") == PngPhoto(3));
  }
  // A new set: opened under the folder's name, which the job takes.
  const std::string fresh = client.UploadImages(photos, "survey", "", {});
  EXPECT_EQ(client.CreateJob(fresh, "", json::object())["input"]["filename"], "survey");
  // Photos that would share a name, or a file that is no image: refused before anything is sent.
  std::ofstream(folder / "DJI_0001.png", std::ios::binary) << PngPhoto(4);
  EXPECT_THROW(client.UploadImages({photos[0], folder / "DJI_0001.png"}, "", "", {}), InputError);
  std::ofstream(folder / "notes.txt") << "x";
  EXPECT_THROW(client.UploadImages({folder / "notes.txt"}, "", "", {}), InputError);
  // A video's upload id is not a set of these photos.
  const std::string video_id = client.UploadFile(video_, "", {});
  EXPECT_THROW(client.UploadImages(photos, "", video_id, {}), InputError);
}

TEST_F(UploadClientTest, RefusalsAreNotRetriedAndAnUnreachableServerIsAnEnvironmentError) {
  Start({}, "client_refusals");
  const fs::path big = dir_ / "big.mp4";
  std::ofstream(big) << std::string(2 << 20, 'x');  // over the 1 MiB limit of the fixture
  UploadClient client(ClientOptions());
  int calls = 0;
  try {
    client.UploadFile(big, "", [&](const UploadProgress&) { ++calls; });
    ADD_FAILURE() << "a file over the limit was accepted";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.status(), 413);
    EXPECT_EQ(e.code(), "payload_too_large");
  }
  EXPECT_EQ(calls, 0);
  try {
    client.CreateJob("0123456789abcdef", "", json::object());
    ADD_FAILURE() << "a job from an unknown upload";
  } catch (const ApiError& e) {
    EXPECT_EQ(e.status(), 404);
  }
  EXPECT_THROW(client.UploadFile(dir_ / "missing.mp4", "", {}), InputError);
  // A file that shrinks while it is sent: the machine failed mid-run (not retried).
  const fs::path shrinking = dir_ / "shrinking.mp4";
  fs::copy_file(video_, shrinking);
  std::vector<UploadProgress> seen;
  try {
    client.UploadFile(shrinking, "", [&](const UploadProgress& p) {
      seen.push_back(p);
      if (p.offset > 0) fs::resize_file(shrinking, 100);
    });
    ADD_FAILURE() << "a file cut while it was sent went through";
  } catch (const EnvironmentError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot read"), std::string::npos) << e.what();
  }
  ASSERT_EQ(seen.size(), 2u);  // the start, one chunk; no retry
  EXPECT_EQ(seen[1].offset, 4096);
  EXPECT_TRUE(seen[1].retry.empty());

  UploadClientOptions nowhere = ClientOptions();
  const int port = port_;
  Stop();  // nothing listens there any more
  nowhere.server = "http://127.0.0.1:" + std::to_string(port);
  UploadClient unreachable(nowhere);
  EXPECT_THROW(unreachable.UploadFile(video_, "", {}), EnvironmentError);

  UploadClientOptions bad = ClientOptions();
  bad.server = "ftp://example.org";
  EXPECT_THROW(UploadClient{bad}, InputError);
  bad.server = "http://127.0.0.1:8080/glam/";
  UploadClient prefixed(bad);
  EXPECT_EQ(prefixed.UrlOf("/?job=x"), "http://127.0.0.1:8080/glam/?job=x");
  bad.chunk_bytes = 10;
  EXPECT_THROW(UploadClient{bad}, InputError);
}

}  // namespace
}  // namespace glam::server
