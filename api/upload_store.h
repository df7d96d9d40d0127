// Resumable uploads (docs/api.md, "Resumable uploads"): a drone video is often several GB
// and sent over a mobile or site link that drops. A one-shot POST /api/v1/jobs then has to
// start again from byte 0; an upload session instead keeps every byte that arrived, across
// dropped connections and server restarts, and the client continues from the offset the
// server reports (the tus.io idea, without its protocol negotiation).
//
// Two kinds of session: a file (a video, or its .SRT track), sent in byte ranges (PATCH), and
// an image set (a photo survey: hundreds of 5-10 MB JPEGs), sent one whole image at a time
// (PUT of one name); a photo is small enough to resend whole, so only complete images count.
//
// On disk, next to the job store (DIR/resumable/):
//   <id>.json    the session: kind, declared size, client name, creation time (written once)
//   <id>.data    a file's bytes received so far; its length *is* the offset, so a crash can
//                never leave the two disagreeing, and nothing needs rewriting per chunk
//   <id>.images/ an image set's complete images (the offset is the sum of their sizes); an
//                image being received is ".<name>.part" there until its last byte is synced
// A session untouched for `expiry` is removed at startup, whenever a session is created, and
// by RemoveExpired (the server calls it every 10 minutes); a file without its partner is
// removed at startup.
//
// Thread-safety: all methods may be called concurrently; one Appender per session at a time
// (a second one is refused with 409 "upload_busy" instead of interleaving bytes).
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace glam::api {

struct UploadStoreOptions {
  std::filesystem::path dir;  // DIR/resumable
  // Largest declared size (the server's --max-upload-mb).
  std::int64_t max_bytes = 20LL << 30;
  // Open sessions at once (503 "too_many_uploads" beyond): each may hold a reservation of
  // disk space, so a client cannot make the server refuse everyone else by opening many.
  int max_sessions = 64;
  // A session whose last byte arrived longer ago than this is removed with its data.
  std::chrono::seconds expiry = std::chrono::hours(24);

  void Check() const;  // throws InputError
};

enum class UploadKind { kFile, kImages };

// "file" or "images", as in the JSON.
const char* UploadKindName(UploadKind kind);

struct StoredImage {
  std::string name;  // api::SafeImageName-clean
  std::int64_t size = 0;
};

struct UploadSession {
  std::string id;
  UploadKind kind = UploadKind::kFile;
  std::string filename;  // as the client named it (display only; never a path)
  std::int64_t size = 0;    // declared total
  std::int64_t offset = 0;  // bytes received (an image set: of its complete images)
  std::int64_t created_ms = 0;
  std::int64_t updated_ms = 0;  // when the last byte arrived (creation if none)
  std::vector<StoredImage> images;  // an image set's images, by name
  bool complete() const { return offset == size; }
};

// The session as JSON: id, kind, filename, size, offset, complete, created_at, updated_at,
// expires_at (ISO 8601 UTC) and url; an image set also image_count and, with `list_images`,
// its images ([{name, size}]): the answer to a photo's PUT leaves the list out, which for a
// survey of thousands of photos would otherwise be larger than the photo.
nlohmann::json UploadToJson(const UploadSession& session, std::chrono::seconds expiry, bool list_images = true);

class UploadStore {
 public:
  // Creates the directory and removes expired sessions and stray files. Throws
  // EnvironmentError when the directory cannot be created.
  explicit UploadStore(UploadStoreOptions options);

  const UploadStoreOptions& options() const { return options_; }

  // A new empty session for `size` bytes. ApiError: 400 "bad_request" (size < 1), 413
  // "payload_too_large" (size > max_bytes), 503 "too_many_uploads", 507
  // "insufficient_storage" (the free disk minus what the open sessions still expect is less
  // than `size`).
  UploadSession Create(std::int64_t size, const std::string& filename, UploadKind kind = UploadKind::kFile);

  // ApiError 400 "invalid_id", 404 "not_found".
  UploadSession Get(const std::string& id) const;

  // Appends bytes to one session; the session is held until destruction. Bytes are written as
  // they arrive and kept whatever happens to the request (that is the point); Finish() makes
  // them durable (fsync) and the destructor does too when Finish() was not reached.
  class Appender {
   public:
    Appender(Appender&& other) noexcept;
    Appender& operator=(Appender&&) = delete;
    Appender(const Appender&) = delete;
    Appender& operator=(const Appender&) = delete;
    ~Appender();

    // Writes what fits in the declared size. False when the chunk went past it (the bytes
    // beyond were dropped: too_large()) or the disk refused it (error_number()).
    bool Write(const char* data, std::size_t size);
    // Flushes and syncs; returns the session as it now is. Throws EnvironmentError (or
    // ApiError 507 for a full disk) when the bytes could not be made durable.
    UploadSession Finish();

    bool too_large() const { return too_large_; }
    int error_number() const { return error_number_; }
    std::int64_t offset() const { return session_.offset; }

   private:
    friend class UploadStore;
    Appender(UploadStore* store, UploadSession session, std::FILE* file);
    bool Close();

    UploadStore* store_;
    UploadSession session_;
    std::FILE* file_;
    bool too_large_ = false;
    int error_number_ = 0;
  };

  // ApiError: 400 / 404 as Get, 409 "upload_busy" (another request is appending), 409
  // "offset_mismatch" (`offset` is not the session's offset: the client resends from the
  // offset GET reports), 409 "upload_complete" (nothing left to send), 409 "wrong_kind" (an
  // image set).
  Appender Append(const std::string& id, std::int64_t offset);

  // Receives one image of an image set, `length` bytes, stored as `name` (replacing an image
  // of that name) only once every byte arrived and was synced; a broken request stores
  // nothing, and the client sends that image again. The session is held until destruction.
  class ImageWriter {
   public:
    ImageWriter(ImageWriter&& other) noexcept;
    ImageWriter& operator=(ImageWriter&&) = delete;
    ImageWriter(const ImageWriter&) = delete;
    ImageWriter& operator=(const ImageWriter&) = delete;
    ~ImageWriter();

    // False when the bytes go past `length` (too_large()) or the disk refused them (Finish()
    // then says why).
    bool Write(const char* data, std::size_t size);
    // Stores the image and returns the session as it now is. ApiError 400 "bad_upload" when
    // fewer than `length` bytes arrived, 507 for a full disk; EnvironmentError otherwise.
    UploadSession Finish();

    bool too_large() const { return too_large_; }

   private:
    friend class UploadStore;
    ImageWriter(UploadStore* store, UploadSession session, std::filesystem::path temp,
                std::filesystem::path final_path, std::int64_t length, std::FILE* file);

    UploadStore* store_;
    // The set as PutImage read it: Finish() updates it for the stored image rather than
    // listing the folder again (a second listing per photo for a survey of thousands).
    UploadSession session_;
    std::filesystem::path temp_;
    std::filesystem::path final_;
    std::int64_t length_;
    std::FILE* file_;
    std::int64_t received_ = 0;
    bool too_large_ = false;
    int error_number_ = 0;
    bool stored_ = false;
  };

  // `name`: as api::SafeImageName makes it. ApiError: 400 / 404 as Get, 400 "bad_image" (not
  // a clean image name, naming the clean one; an empty image; more than kMaxImagesPerJob
  // images), 409 "upload_busy", 409 "wrong_kind" (a file session), 413 "payload_too_large"
  // (the set's declared size cannot hold it).
  ImageWriter PutImage(const std::string& id, const std::string& name, std::int64_t length);

  // Ends a complete session and moves its bytes (a file; an image set: the folder of its
  // images) to `destination` (same file system); the session is gone afterwards. ApiError:
  // 400 / 404 as Get, 409 "upload_busy", 409 "upload_incomplete". Returns the session as it
  // was.
  UploadSession Take(const std::string& id, const std::filesystem::path& destination);

  // A complete session, checked as Take checks it, left in place.
  UploadSession GetComplete(const std::string& id) const;

  // The data file of a complete file session, to read (a telemetry track); the session stays.
  // Same errors as Take, and 409 "wrong_kind" for an image set.
  std::filesystem::path CompleteDataFile(const std::string& id) const;

  // Removes the session and its bytes. 400 / 404 as Get, 409 "upload_busy".
  void Remove(const std::string& id);

  // Removes sessions whose last byte is older than the expiry; returns how many.
  int RemoveExpired();

  int open_sessions() const;

 private:
  std::filesystem::path MetaPath(const std::string& id) const;
  std::filesystem::path DataPath(const std::string& id) const;
  std::filesystem::path ImagesPath(const std::string& id) const;
  // Removes a session's files, whichever kind.
  void RemoveFilesLocked(const std::string& id) const;
  // Reads a session from disk (400 for a malformed id, 404 when missing). Under mutex_.
  UploadSession LoadLocked(const std::string& id) const;
  // As LoadLocked, and 409 unless no Appender holds it and every byte arrived.
  UploadSession LoadCompleteLocked(const std::string& id) const;
  std::vector<UploadSession> ListLocked() const;
  void Release(const std::string& id);
  // An ImageWriter stored `image` in set `id`: the set's list in image_lists_ learns it.
  void ImageStored(const std::string& id, const StoredImage& image);

  UploadStoreOptions options_;
  mutable std::mutex mutex_;
  std::set<std::string> busy_;  // sessions with an Appender
  // Each image set's stored images, listed from its folder once (the first time it is read
  // after a start) and then kept up to date by the store, the folder's only writer. Reading
  // the folder on every request (a stat per image) cost a set of 2000 photos ~3 ms per PUT,
  // growing with the set, and every upload opened re-read every open set.
  mutable std::map<std::string, std::vector<StoredImage>> image_lists_;
};

}  // namespace glam::api
