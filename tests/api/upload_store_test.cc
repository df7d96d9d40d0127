// Resumable upload sessions on disk (api/upload_store.h) without HTTP: offsets, the one-writer
// rule, the size limit, disk reservations, hand-off to a job, expiry and what survives a
// reopen (a server restart), for files and for image sets.
#include "api/upload_store.h"

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>

#include <gtest/gtest.h>

#include "api/api_error.h"
#include "engine/core/error.h"
#include "tests/api/api_error_test_util.h"
#include "tests/support/temp_dir.h"

namespace glam::api {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using testing::CodeOf;
using testing::StatusOf;

std::string ReadAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

UploadStoreOptions Options(const fs::path& dir) {
  UploadStoreOptions o;
  o.dir = dir / "resumable";
  o.max_bytes = 1000;
  o.max_sessions = 3;
  return o;
}

void Send(UploadStore& store, const std::string& id, std::int64_t offset, const std::string& bytes) {
  UploadStore::Appender appender = store.Append(id, offset);
  ASSERT_TRUE(appender.Write(bytes.data(), bytes.size()));
  EXPECT_EQ(appender.Finish().offset, offset + static_cast<std::int64_t>(bytes.size()));
}

TEST(UploadStore, ChunksAppendAtTheRightOffsetAndTheFileMovesToTheJob) {
  const fs::path dir = glam::testing::FreshTempDir("upload_store_chunks");
  UploadStore store(Options(dir));
  const UploadSession created = store.Create(10, "survey/../DJI_0001.MP4");
  EXPECT_EQ(created.filename, "DJI_0001.MP4");  // no directories
  EXPECT_EQ(created.offset, 0);
  EXPECT_FALSE(created.complete());

  Send(store, created.id, 0, "0123");
  // Resending from an old offset (the client missed the answer) is refused with the truth.
  EXPECT_EQ(CodeOf([&] { store.Append(created.id, 0); }), "offset_mismatch");
  EXPECT_EQ(CodeOf([&] { store.Append(created.id, 7); }), "offset_mismatch");
  EXPECT_EQ(store.Get(created.id).offset, 4);
  // Not yet a job.
  EXPECT_EQ(CodeOf([&] { store.Take(created.id, dir / "video"); }), "upload_incomplete");
  EXPECT_EQ(CodeOf([&] { store.CompleteDataFile(created.id); }), "upload_incomplete");

  Send(store, created.id, 4, "456789");
  const UploadSession done = store.Get(created.id);
  EXPECT_TRUE(done.complete());
  EXPECT_EQ(CodeOf([&] { store.Append(created.id, 10); }), "upload_complete");
  EXPECT_EQ(ReadAll(store.CompleteDataFile(created.id)), "0123456789");

  const UploadSession taken = store.Take(created.id, dir / "video");
  EXPECT_EQ(taken.filename, "DJI_0001.MP4");
  EXPECT_EQ(ReadAll(dir / "video"), "0123456789");
  EXPECT_EQ(StatusOf([&] { store.Get(created.id); }), 404);
  EXPECT_TRUE(fs::is_empty(dir / "resumable"));
}

TEST(UploadStore, OneWriterAtATimeAndNothingPastTheDeclaredSize) {
  const fs::path dir = glam::testing::FreshTempDir("upload_store_writer");
  UploadStore store(Options(dir));
  const std::string id = store.Create(6, "a.mp4").id;
  {
    UploadStore::Appender first = store.Append(id, 0);
    EXPECT_EQ(CodeOf([&] { store.Append(id, 0); }), "upload_busy");
    EXPECT_EQ(CodeOf([&] { store.Remove(id); }), "upload_busy");
    ASSERT_TRUE(first.Write("abc", 3));
    // A body longer than what is left: the bytes up to the size are kept, the rest dropped.
    EXPECT_FALSE(first.Write("defgh", 5));
    EXPECT_TRUE(first.too_large());
    EXPECT_EQ(first.Finish().offset, 6);
  }
  EXPECT_EQ(ReadAll(store.CompleteDataFile(id)), "abcdef");
  // A writer that never reached Finish() (its request died) still leaves its bytes durable
  // and the session free.
  const std::string other = store.Create(4, "b.mp4").id;
  {
    UploadStore::Appender broken = store.Append(other, 0);
    ASSERT_TRUE(broken.Write("xy", 2));
  }
  EXPECT_EQ(store.Get(other).offset, 2);
  Send(store, other, 2, "zw");
  store.Remove(other);
  EXPECT_EQ(StatusOf([&] { store.Get(other); }), 404);
}

TEST(UploadStore, LimitsAndBadIds) {
  const fs::path dir = glam::testing::FreshTempDir("upload_store_limits");
  UploadStore store(Options(dir));
  EXPECT_EQ(StatusOf([&] { store.Create(0, "a"); }), 400);
  EXPECT_EQ(StatusOf([&] { store.Create(1001, "a"); }), 413);
  EXPECT_EQ(StatusOf([&] { store.Get("../../etc/passwd"); }), 400);
  EXPECT_EQ(StatusOf([&] { store.Get("0123456789abcdef"); }), 404);
  for (int i = 0; i < 3; ++i) store.Create(10, "a");
  EXPECT_EQ(CodeOf([&] { store.Create(10, "a"); }), "too_many_uploads");
  EXPECT_EQ(store.open_sessions(), 3);
}

TEST(UploadStore, OpenUploadsReserveTheirRemainingBytesOfDisk) {
  const fs::path dir = glam::testing::FreshTempDir("upload_store_disk");
  UploadStoreOptions options = Options(dir);
  options.max_bytes = std::int64_t{1} << 60;
  UploadStore store(options);
  const auto available = static_cast<std::int64_t>(fs::space(dir).available);
  EXPECT_EQ(CodeOf([&] { store.Create(available * 2, "too big"); }), "insufficient_storage");
  // Each fits alone; the second does not fit beside what the first still expects.
  const std::string first = store.Create(available / 10 * 6, "first").id;
  EXPECT_EQ(CodeOf([&] { store.Create(available / 10 * 6, "second"); }), "insufficient_storage");
  store.Remove(first);
  EXPECT_NO_THROW(store.Create(available / 10 * 6, "second"));
}

TEST(UploadStore, SessionsSurviveAReopenAndExpireAfterTheirLastByte) {
  const fs::path dir = glam::testing::FreshTempDir("upload_store_reopen");
  std::string kept, stale;
  {
    UploadStore store(Options(dir));
    kept = store.Create(8, "kept.mp4").id;
    Send(store, kept, 0, "1234");
    stale = store.Create(8, "stale.mp4").id;
    Send(store, stale, 0, "12");
  }
  // The process stopped: a stray data file (stopped inside Create) and a foreign file.
  std::ofstream(dir / "resumable" / "0123456789abcdef.data") << "x";
  std::ofstream(dir / "resumable" / "notes.txt") << "x";
  // The stale upload's last byte arrived two days ago.
  fs::last_write_time(dir / "resumable" / (stale + ".data"), fs::file_time_type::clock::now() - 48h);

  UploadStore reopened(Options(dir));
  const UploadSession s = reopened.Get(kept);
  EXPECT_EQ(s.offset, 4);
  EXPECT_EQ(s.size, 8);
  EXPECT_EQ(s.filename, "kept.mp4");
  EXPECT_EQ(StatusOf([&] { reopened.Get(stale); }), 404);
  EXPECT_FALSE(fs::exists(dir / "resumable" / "0123456789abcdef.data"));
  EXPECT_FALSE(fs::exists(dir / "resumable" / "notes.txt"));
  Send(reopened, kept, 4, "5678");
  EXPECT_EQ(ReadAll(reopened.CompleteDataFile(kept)), "12345678");

  // Expiry while running: swept on the next Create (and by RemoveExpired).
  fs::last_write_time(dir / "resumable" / (kept + ".data"), fs::file_time_type::clock::now() - 25h);
  EXPECT_EQ(reopened.RemoveExpired(), 1);
  EXPECT_EQ(reopened.open_sessions(), 0);
}

// Stores one image of a set whole; the set Finish() returns is the one on disk.
void PutImage(UploadStore& store, const std::string& id, const std::string& name, const std::string& bytes) {
  UploadStore::ImageWriter writer = store.PutImage(id, name, static_cast<std::int64_t>(bytes.size()));
  ASSERT_TRUE(writer.Write(bytes.data(), bytes.size()));
  const UploadSession returned = writer.Finish();
  const UploadSession stored = store.Get(id);
  EXPECT_EQ(returned.offset, stored.offset);
  ASSERT_EQ(returned.images.size(), stored.images.size());
  for (std::size_t i = 0; i < stored.images.size(); ++i) {
    EXPECT_EQ(returned.images[i].name, stored.images[i].name);
    EXPECT_EQ(returned.images[i].size, stored.images[i].size);
  }
}

TEST(UploadStore, AnImageSetKeepsWholeImagesOnlyAndBecomesTheJobsFolder) {
  const fs::path dir = glam::testing::FreshTempDir("upload_store_images");
  UploadStore store(Options(dir));
  const UploadSession created = store.Create(12, "", UploadKind::kImages);
  EXPECT_EQ(created.kind, UploadKind::kImages);
  EXPECT_TRUE(created.images.empty());
  // Not a file: no byte ranges, no telemetry.
  EXPECT_EQ(CodeOf([&] { store.Append(created.id, 0); }), "wrong_kind");

  PutImage(store, created.id, "DJI_0001.JPG", "aaaa");
  // A request that breaks inside an image stores nothing of it; the set stays free.
  {
    UploadStore::ImageWriter broken = store.PutImage(created.id, "DJI_0002.JPG", 4);
    EXPECT_EQ(CodeOf([&] { store.PutImage(created.id, "DJI_0003.JPG", 4); }), "upload_busy");
    ASSERT_TRUE(broken.Write("bb", 2));
    EXPECT_EQ(CodeOf([&] { broken.Finish(); }), "bad_upload");
  }
  {
    UploadStore::ImageWriter dropped = store.PutImage(created.id, "DJI_0002.JPG", 4);
    ASSERT_TRUE(dropped.Write("bb", 2));
  }  // the connection died: never finished
  UploadSession s = store.Get(created.id);
  ASSERT_EQ(s.images.size(), 1u);
  EXPECT_EQ(s.images[0].name, "DJI_0001.JPG");
  EXPECT_EQ(s.offset, 4);
  EXPECT_EQ(fs::directory_iterator(dir / "resumable" / (created.id + ".images"))->path().filename(), "DJI_0001.JPG");

  // Refusals: names that are not clean image names, empty images, more than the declared size.
  EXPECT_EQ(CodeOf([&] { store.PutImage(created.id, "../x.jpg", 4); }), "bad_image");
  EXPECT_EQ(CodeOf([&] { store.PutImage(created.id, ".hidden.jpg", 4); }), "bad_image");
  EXPECT_EQ(CodeOf([&] { store.PutImage(created.id, "notes.txt", 4); }), "bad_image");
  EXPECT_EQ(CodeOf([&] { store.PutImage(created.id, "a.jpg", 0); }), "bad_image");
  EXPECT_EQ(CodeOf([&] { store.PutImage(created.id, "big.jpg", 9); }), "payload_too_large");
  EXPECT_EQ(CodeOf([&] { store.Take(created.id, dir / "photos"); }), "upload_incomplete");

  PutImage(store, created.id, "DJI_0002.JPG", "bb");
  // Sent again (the client missed the answer, or the photo changed): replaced, not counted twice.
  PutImage(store, created.id, "DJI_0002.JPG", "BBBB");
  PutImage(store, created.id, "DJI_0003.JPG", "cccc");
  s = store.Get(created.id);
  EXPECT_TRUE(s.complete());
  EXPECT_EQ(s.images.size(), 3u);
  EXPECT_EQ(CodeOf([&] { store.CompleteDataFile(created.id); }), "wrong_kind");

  const UploadSession taken = store.Take(created.id, dir / "photos");
  EXPECT_EQ(taken.images.size(), 3u);
  EXPECT_EQ(ReadAll(dir / "photos" / "DJI_0001.JPG"), "aaaa");
  EXPECT_EQ(ReadAll(dir / "photos" / "DJI_0002.JPG"), "BBBB");
  EXPECT_EQ(ReadAll(dir / "photos" / "DJI_0003.JPG"), "cccc");
  EXPECT_EQ(StatusOf([&] { store.Get(created.id); }), 404);
  EXPECT_TRUE(fs::is_empty(dir / "resumable"));
}

TEST(UploadStore, AnImageSetSurvivesAReopenWithoutTheImageThatWasArriving) {
  const fs::path dir = glam::testing::FreshTempDir("upload_store_images_reopen");
  std::string id;
  {
    UploadStore store(Options(dir));
    id = store.Create(8, "survey", UploadKind::kImages).id;
    PutImage(store, id, "a.jpg", "1234");
  }
  // The process stopped inside the second image.
  std::ofstream(dir / "resumable" / (id + ".images") / ".b.jpg.part") << "56";
  UploadStore reopened(Options(dir));
  const UploadSession s = reopened.Get(id);
  EXPECT_EQ(s.kind, UploadKind::kImages);
  EXPECT_EQ(s.filename, "survey");
  EXPECT_EQ(s.offset, 4);
  EXPECT_FALSE(fs::exists(dir / "resumable" / (id + ".images") / ".b.jpg.part"));
  PutImage(reopened, id, "b.jpg", "5678");
  EXPECT_TRUE(reopened.Get(id).complete());
  // Expired like a file, folder and all.
  fs::last_write_time(dir / "resumable" / (id + ".images"), fs::file_time_type::clock::now() - 25h);
  EXPECT_EQ(reopened.RemoveExpired(), 1);
  EXPECT_TRUE(fs::is_empty(dir / "resumable"));
}

TEST(UploadStore, OptionsAreChecked) {
  const fs::path dir = glam::testing::FreshTempDir("upload_store_options");
  UploadStoreOptions o = Options(dir);
  o.max_sessions = 0;
  EXPECT_THROW(UploadStore{o}, InputError);
  o = Options(dir);
  o.expiry = 10s;
  EXPECT_THROW(UploadStore{o}, InputError);
  o = Options(dir);
  o.dir.clear();
  EXPECT_THROW(UploadStore{o}, InputError);
}

TEST(UploadStore, JsonNamesTheOffsetAndTheExpiry) {
  UploadSession s;
  s.id = "0123456789abcdef";
  s.filename = "a.mp4";
  s.size = 10;
  s.offset = 4;
  s.created_ms = 1'000'000;
  s.updated_ms = 2'000'000;
  const nlohmann::json j = UploadToJson(s, std::chrono::hours(1));
  EXPECT_EQ(j["offset"], 4);
  EXPECT_EQ(j["size"], 10);
  EXPECT_EQ(j["complete"], false);
  EXPECT_EQ(j["url"], "/api/v1/uploads/0123456789abcdef");
  EXPECT_EQ(j["updated_at"], "1970-01-01T00:33:20.000Z");
  EXPECT_EQ(j["expires_at"], "1970-01-01T01:33:20.000Z");
  EXPECT_EQ(j["kind"], "file");
  EXPECT_FALSE(j.contains("images"));
  s.kind = UploadKind::kImages;
  s.images = {{"a.jpg", 3}, {"b.jpg", 1}};
  const nlohmann::json set = UploadToJson(s, std::chrono::hours(1));
  EXPECT_EQ(set["kind"], "images");
  EXPECT_EQ(set["images"], nlohmann::json::parse(R"([{"name": "a.jpg", "size": 3}, {"name": "b.jpg", "size": 1}])"));
  EXPECT_EQ(set["image_count"], 2);
  const nlohmann::json brief = UploadToJson(s, std::chrono::hours(1), /*list_images=*/false);
  EXPECT_FALSE(brief.contains("images"));
  EXPECT_EQ(brief["image_count"], 2);
}

}  // namespace
}  // namespace glam::api
