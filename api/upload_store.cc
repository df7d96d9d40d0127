#include "api/upload_store.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "api/api_error.h"
#include "api/ids.h"
#include "api/image_names.h"
#include "api/job.h"
#include "api/job_json.h"
#include "engine/core/atomic_file.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"

namespace glam::api {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kMetaSuffix = ".json";
constexpr const char* kDataSuffix = ".data";
constexpr const char* kImagesSuffix = ".images";

// The client's name without directories, at most 200 characters ("upload" when empty).
std::string CleanFilename(const std::string& name) {
  const auto slash = name.find_last_of("/\\");
  std::string out = slash == std::string::npos ? name : name.substr(slash + 1);
  if (out.size() > 200) out.erase(0, out.size() - 200);  // keeps the extension
  return out.empty() ? "upload" : out;
}

// Length and modification time (epoch ms) of a file; false when it does not exist.
bool StatFile(const fs::path& path, std::int64_t* size, std::int64_t* mtime_ms) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return false;
  *size = static_cast<std::int64_t>(st.st_size);
  *mtime_ms = static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1000 + st.st_mtim.tv_nsec / 1000000;
  return true;
}

void RemoveQuietly(const fs::path& path) {
  std::error_code ec;
  fs::remove_all(path, ec);
  if (ec) GLAM_LOG_WARN("cannot remove {}: {}", path.string(), ec.message());
}

// An image set's images (not the ones still arriving: ".<name>.part"), by name.
std::vector<StoredImage> ListImages(const fs::path& folder) {
  std::vector<StoredImage> images;
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
    const std::string name = entry.path().filename().string();
    std::int64_t size = 0, mtime = 0;
    if (name.empty() || name.front() == '.' || !StatFile(entry.path(), &size, &mtime)) continue;
    images.push_back({name, size});
  }
  std::sort(images.begin(), images.end(), [](const StoredImage& a, const StoredImage& b) { return a.name < b.name; });
  return images;
}

[[noreturn]] void ThrowWrongKind(const std::string& id, UploadKind kind) {
  throw ApiError(409, "wrong_kind",
                 kind == UploadKind::kImages
                     ? fmt::format("upload {} is an image set: PUT each image to /api/v1/uploads/{}/images/{{name}}",
                                   id, id)
                     : fmt::format("upload {} is a single file: PATCH its bytes to /api/v1/uploads/{}", id, id));
}

[[noreturn]] void ThrowStorageError(int error_number, const std::string& what) {
  if (error_number == ENOSPC || error_number == EDQUOT || error_number == EFBIG) {
    throw ApiError(507, "insufficient_storage", fmt::format("{}: the server's disk is full", what));
  }
  throw EnvironmentError(fmt::format("{}: {}", what, std::strerror(error_number)));
}

}  // namespace

void UploadStoreOptions::Check() const {
  if (dir.empty()) throw InputError("the upload directory is not set");
  if (max_bytes < 1) throw InputError("the upload size limit must be at least 1 byte");
  if (max_sessions < 1) throw InputError(fmt::format("--max-open-uploads must be at least 1, got {}", max_sessions));
  if (expiry.count() < 60) {
    throw InputError(fmt::format("the upload expiry must be at least 60 s, got {} s", expiry.count()));
  }
}

const char* UploadKindName(UploadKind kind) { return kind == UploadKind::kImages ? "images" : "file"; }

json UploadToJson(const UploadSession& s, std::chrono::seconds expiry, bool list_images) {
  const std::int64_t expires_ms = s.updated_ms + std::chrono::duration_cast<std::chrono::milliseconds>(expiry).count();
  json j = {{"id", s.id},
            {"kind", UploadKindName(s.kind)},
            {"filename", s.filename},
            {"size", s.size},
            {"offset", s.offset},
            {"complete", s.complete()},
            {"created_at", FormatTimestamp(s.created_ms)},
            {"updated_at", FormatTimestamp(s.updated_ms)},
            {"expires_at", FormatTimestamp(expires_ms)},
            {"url", "/api/v1/uploads/" + s.id}};
  if (s.kind == UploadKind::kImages) {
    j["image_count"] = s.images.size();
    if (list_images) {
      json images = json::array();
      for (const StoredImage& image : s.images) images.push_back({{"name", image.name}, {"size", image.size}});
      j["images"] = std::move(images);
    }
  }
  return j;
}

UploadStore::UploadStore(UploadStoreOptions options) : options_(std::move(options)) {
  options_.Check();
  std::error_code ec;
  fs::create_directories(options_.dir, ec);
  if (ec) {
    throw EnvironmentError(fmt::format("cannot create upload directory {}: {}", options_.dir.string(), ec.message()));
  }
  // Stray files: a data file or image folder without its session (the process stopped
  // inside Create) or a session without data (removed by hand), images that were still
  // arriving when the process stopped, and anything else.
  std::vector<fs::path> entries;
  for (const fs::directory_entry& entry : fs::directory_iterator(options_.dir, ec)) entries.push_back(entry.path());
  for (const fs::path& p : entries) {
    const std::string id = p.stem().string();
    const std::string ext = p.extension().string();
    const bool ours = IsValidJobId(id) && (ext == kMetaSuffix || ext == kDataSuffix || ext == kImagesSuffix);
    const bool partnered = ext == kMetaSuffix ? fs::exists(DataPath(id)) || fs::exists(ImagesPath(id))
                                              : fs::exists(MetaPath(id));
    if (!ours || !partnered) {
      GLAM_LOG_INFO("removing stray upload file {}", p.string());
      RemoveQuietly(p);
      continue;
    }
    if (ext != kImagesSuffix) continue;
    for (const fs::directory_entry& image : fs::directory_iterator(p, ec)) {
      if (image.path().filename().string().front() != '.') continue;
      GLAM_LOG_INFO("removing {}: its request ended before its last byte", image.path().string());
      RemoveQuietly(image.path());
    }
  }
  const int expired = RemoveExpired();
  const int open = open_sessions();
  if (open > 0 || expired > 0) {
    GLAM_LOG_INFO("{} resumable uploads open, {} expired ones removed", open, expired);
  }
}

fs::path UploadStore::MetaPath(const std::string& id) const { return options_.dir / (id + kMetaSuffix); }
fs::path UploadStore::DataPath(const std::string& id) const { return options_.dir / (id + kDataSuffix); }
fs::path UploadStore::ImagesPath(const std::string& id) const { return options_.dir / (id + kImagesSuffix); }

void UploadStore::RemoveFilesLocked(const std::string& id) const {
  RemoveQuietly(MetaPath(id));
  RemoveQuietly(DataPath(id));
  RemoveQuietly(ImagesPath(id));
  image_lists_.erase(id);
}

UploadSession UploadStore::LoadLocked(const std::string& id) const {
  if (!IsValidJobId(id)) {
    throw ApiError(400, "invalid_id", fmt::format("\"{}\" is not an upload id (16 hex characters)", id));
  }
  UploadSession s;
  s.id = id;
  const auto not_found = [&id] {
    return ApiError(404, "not_found", fmt::format("no upload with id {} (it may have expired)", id));
  };
  std::int64_t meta_size = 0, meta_mtime = 0;
  if (!StatFile(MetaPath(id), &meta_size, &meta_mtime)) {
    image_lists_.erase(id);
    throw not_found();
  }
  std::ifstream in(MetaPath(id));
  std::stringstream text;
  text << in.rdbuf();
  const json meta = json::parse(text.str(), nullptr, /*allow_exceptions=*/false);
  if (!meta.is_object() || !meta.contains("size") || !meta["size"].is_number_integer()) {
    throw EnvironmentError(fmt::format("upload record {} is unreadable", MetaPath(id).string()));
  }
  s.kind = meta.value("kind", std::string("file")) == "images" ? UploadKind::kImages : UploadKind::kFile;
  s.size = meta["size"].get<std::int64_t>();
  s.filename = meta.value("filename", std::string("upload"));
  s.created_ms = meta.value("created_ms", meta_mtime);
  if (s.kind == UploadKind::kFile) {
    if (!StatFile(DataPath(id), &s.offset, &s.updated_ms)) throw not_found();
    return s;
  }
  // An image set: its folder's time changes as an image starts and as it is stored.
  std::int64_t folder_size = 0;
  if (!StatFile(ImagesPath(id), &folder_size, &s.updated_ms)) {
    image_lists_.erase(id);
    throw not_found();
  }
  auto listed = image_lists_.find(id);
  if (listed == image_lists_.end()) listed = image_lists_.emplace(id, ListImages(ImagesPath(id))).first;
  s.images = listed->second;
  for (const StoredImage& image : s.images) s.offset += image.size;
  return s;
}

std::vector<UploadSession> UploadStore::ListLocked() const {
  std::vector<UploadSession> out;
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(options_.dir, ec)) {
    if (entry.path().extension() != kMetaSuffix) continue;
    try {
      out.push_back(LoadLocked(entry.path().stem().string()));
    } catch (const std::exception&) {
      // Removed meanwhile, or not ours: the constructor's sweep handles strays.
    }
  }
  return out;
}

int UploadStore::open_sessions() const {
  std::lock_guard lock(mutex_);
  return static_cast<int>(ListLocked().size());
}

UploadSession UploadStore::Create(std::int64_t size, const std::string& filename, UploadKind kind) {
  if (size < 1) throw ApiError(400, "bad_request", fmt::format("size must be at least 1 byte, got {}", size));
  if (size > options_.max_bytes) {
    throw ApiError(413, "payload_too_large",
                   fmt::format("the upload would have {} bytes; the limit is {} bytes", size, options_.max_bytes));
  }
  RemoveExpired();
  std::lock_guard lock(mutex_);
  const std::vector<UploadSession> open = ListLocked();
  if (static_cast<int>(open.size()) >= options_.max_sessions) {
    throw ApiError(503, "too_many_uploads",
                   fmt::format("{} resumable uploads are open (limit {}); finish or delete one, or try later",
                               open.size(), options_.max_sessions));
  }
  // Space the open sessions will still need is as good as taken.
  std::int64_t expected = 0;
  for (const UploadSession& s : open) expected += s.size - s.offset;
  std::error_code ec;
  const fs::space_info space = fs::space(options_.dir, ec);
  if (!ec && static_cast<std::int64_t>(space.available) - expected < size) {
    throw ApiError(507, "insufficient_storage",
                   fmt::format("the upload would have {} bytes but only {} bytes are free ({} of them promised to "
                               "open uploads)",
                               size, space.available, expected));
  }
  UploadSession s;
  do {
    s.id = NewJobId();
  } while (fs::exists(MetaPath(s.id)) || fs::exists(DataPath(s.id)) || fs::exists(ImagesPath(s.id)));
  s.kind = kind;
  s.filename = CleanFilename(filename);
  s.size = size;
  s.created_ms = NowMs();
  s.updated_ms = s.created_ms;
  // The data file (or image folder) first: a stray one is removed at startup, a session
  // without it is not.
  if (kind == UploadKind::kImages) {
    if (::mkdir(ImagesPath(s.id).c_str(), 0755) != 0) {
      ThrowStorageError(errno, fmt::format("cannot create {}", ImagesPath(s.id).string()));
    }
  } else {
    std::FILE* data = std::fopen(DataPath(s.id).c_str(), "wb");
    if (data == nullptr) ThrowStorageError(errno, fmt::format("cannot create {}", DataPath(s.id).string()));
    std::fclose(data);
  }
  try {
    WriteFileAtomically(MetaPath(s.id), json{{"kind", UploadKindName(kind)},
                                             {"size", s.size},
                                             {"filename", s.filename},
                                             {"created_ms", s.created_ms}}
                                            .dump());
  } catch (...) {
    RemoveFilesLocked(s.id);
    throw;
  }
  GLAM_LOG_INFO("upload {} opened: {} bytes of {} ({})", s.id, s.size, s.filename, UploadKindName(kind));
  return s;
}

UploadSession UploadStore::Get(const std::string& id) const {
  std::lock_guard lock(mutex_);
  return LoadLocked(id);
}

UploadStore::Appender UploadStore::Append(const std::string& id, std::int64_t offset) {
  std::lock_guard lock(mutex_);
  const UploadSession s = LoadLocked(id);
  if (s.kind != UploadKind::kFile) ThrowWrongKind(id, s.kind);
  if (busy_.count(id)) {
    throw ApiError(409, "upload_busy", fmt::format("another request is sending bytes of upload {}", id));
  }
  if (offset != s.offset) {
    throw ApiError(409, "offset_mismatch",
                   fmt::format("upload {} has {} bytes; send from offset {}, not {}", id, s.offset, s.offset, offset));
  }
  if (s.complete()) {
    throw ApiError(409, "upload_complete", fmt::format("upload {} already has all its {} bytes", id, s.size));
  }
  std::FILE* file = std::fopen(DataPath(id).c_str(), "ab");
  if (file == nullptr) ThrowStorageError(errno, fmt::format("cannot open {}", DataPath(id).string()));
  busy_.insert(id);
  return Appender(this, s, file);
}

UploadSession UploadStore::LoadCompleteLocked(const std::string& id) const {
  const UploadSession s = LoadLocked(id);
  if (busy_.count(id)) {
    throw ApiError(409, "upload_busy", fmt::format("another request is sending bytes of upload {}", id));
  }
  if (!s.complete()) {
    throw ApiError(409, "upload_incomplete",
                   fmt::format("upload {} has {} of its {} bytes; send the rest first", id, s.offset, s.size));
  }
  return s;
}

UploadSession UploadStore::Take(const std::string& id, const fs::path& destination) {
  std::lock_guard lock(mutex_);
  const UploadSession s = LoadCompleteLocked(id);
  std::error_code ec;
  fs::rename(s.kind == UploadKind::kImages ? ImagesPath(id) : DataPath(id), destination, ec);
  if (ec) throw EnvironmentError(fmt::format("cannot move upload {}: {}", id, ec.message()));
  RemoveQuietly(MetaPath(id));
  image_lists_.erase(id);
  GLAM_LOG_INFO("upload {} complete ({} bytes{}), handed to a job", id, s.size,
                s.kind == UploadKind::kImages ? fmt::format(", {} images", s.images.size()) : std::string());
  return s;
}

UploadSession UploadStore::GetComplete(const std::string& id) const {
  std::lock_guard lock(mutex_);
  return LoadCompleteLocked(id);
}

fs::path UploadStore::CompleteDataFile(const std::string& id) const {
  std::lock_guard lock(mutex_);
  const UploadSession s = LoadCompleteLocked(id);
  if (s.kind != UploadKind::kFile) ThrowWrongKind(id, s.kind);
  return DataPath(id);
}

void UploadStore::Remove(const std::string& id) {
  std::lock_guard lock(mutex_);
  LoadLocked(id);
  if (busy_.count(id)) {
    throw ApiError(409, "upload_busy", fmt::format("another request is sending bytes of upload {}", id));
  }
  RemoveFilesLocked(id);
  GLAM_LOG_INFO("upload {} deleted", id);
}

int UploadStore::RemoveExpired() {
  std::lock_guard lock(mutex_);
  const std::int64_t cutoff = NowMs() - std::chrono::duration_cast<std::chrono::milliseconds>(options_.expiry).count();
  int removed = 0;
  for (const UploadSession& s : ListLocked()) {
    if (busy_.count(s.id) || s.updated_ms >= cutoff) continue;
    GLAM_LOG_INFO("upload {} expired ({} of {} bytes, last byte at {}): removed", s.id, s.offset, s.size,
                  FormatTimestamp(s.updated_ms));
    RemoveFilesLocked(s.id);
    ++removed;
  }
  return removed;
}

UploadStore::ImageWriter UploadStore::PutImage(const std::string& id, const std::string& name, std::int64_t length) {
  std::lock_guard lock(mutex_);
  const UploadSession s = LoadLocked(id);
  if (s.kind != UploadKind::kImages) ThrowWrongKind(id, s.kind);
  if (busy_.count(id)) {
    throw ApiError(409, "upload_busy", fmt::format("another request is sending an image of upload {}", id));
  }
  if (const std::string why = UncleanImageNameMessage(name); !why.empty()) throw ApiError(400, "bad_image", why);
  if (length < 1) throw ApiError(400, "bad_image", fmt::format("image \"{}\" is empty", name));
  const auto same = std::find_if(s.images.begin(), s.images.end(), [&](const StoredImage& i) { return i.name == name; });
  const std::int64_t replaced = same != s.images.end() ? same->size : 0;
  if (same == s.images.end() && s.images.size() >= kMaxImagesPerJob) {
    throw ApiError(400, "bad_image", fmt::format("more than {} images in one job", kMaxImagesPerJob));
  }
  if (s.offset - replaced + length > s.size) {
    throw ApiError(413, "payload_too_large",
                   fmt::format("image \"{}\" ({} bytes) does not fit in the set's declared size: {} of {} bytes are "
                               "taken{}",
                               name, length, s.offset - replaced, s.size,
                               replaced > 0 ? " by the other images" : ""));
  }
  const fs::path temp = ImagesPath(id) / ("." + name + ".part");
  std::FILE* file = std::fopen(temp.c_str(), "wb");
  if (file == nullptr) ThrowStorageError(errno, fmt::format("cannot create {}", temp.string()));
  busy_.insert(id);
  return ImageWriter(this, s, temp, ImagesPath(id) / name, length, file);
}

void UploadStore::Release(const std::string& id) {
  std::lock_guard lock(mutex_);
  busy_.erase(id);
}

void UploadStore::ImageStored(const std::string& id, const StoredImage& image) {
  std::lock_guard lock(mutex_);
  const auto listed = image_lists_.find(id);
  if (listed == image_lists_.end()) return;  // listed from the folder when next read
  std::vector<StoredImage>& images = listed->second;
  const auto at = std::lower_bound(images.begin(), images.end(), image.name,
                                   [](const StoredImage& i, const std::string& n) { return i.name < n; });
  if (at != images.end() && at->name == image.name) {
    at->size = image.size;
  } else {
    images.insert(at, image);
  }
}

UploadStore::Appender::Appender(UploadStore* store, UploadSession session, std::FILE* file)
    : store_(store), session_(std::move(session)), file_(file) {}

UploadStore::Appender::Appender(Appender&& other) noexcept
    : store_(other.store_), session_(std::move(other.session_)), file_(other.file_),
      too_large_(other.too_large_), error_number_(other.error_number_) {
  other.store_ = nullptr;
  other.file_ = nullptr;
}

UploadStore::Appender::~Appender() {
  if (store_ == nullptr) return;
  Close();
  store_->Release(session_.id);
}

bool UploadStore::Appender::Write(const char* data, std::size_t size) {
  if (file_ == nullptr || error_number_ != 0) return false;
  const std::int64_t room = session_.size - session_.offset;
  const std::size_t n = static_cast<std::int64_t>(size) > room ? static_cast<std::size_t>(room) : size;
  if (n > 0) {
    const std::size_t written = std::fwrite(data, 1, n, file_);
    session_.offset += static_cast<std::int64_t>(written);
    if (written != n) {
      error_number_ = errno != 0 ? errno : EIO;
      return false;
    }
  }
  if (n < size) {
    too_large_ = true;
    return false;
  }
  return true;
}

bool UploadStore::Appender::Close() {
  if (file_ == nullptr) return error_number_ == 0;
  const bool ok = std::fflush(file_) == 0 && ::fsync(fileno(file_)) == 0;
  if (!ok && error_number_ == 0) error_number_ = errno;
  std::fclose(file_);
  file_ = nullptr;
  return ok;
}

UploadSession UploadStore::Appender::Finish() {
  const bool ok = Close();
  // The file is the truth: after a short write, what landed on disk is the offset.
  UploadSession now = store_->Get(session_.id);
  if (!ok || error_number_ != 0) {
    ThrowStorageError(error_number_, fmt::format("upload {} kept only the bytes that could be stored ({})",
                                                 session_.id, now.offset));
  }
  return now;
}

}  // namespace glam::api

namespace glam::api {

UploadStore::ImageWriter::ImageWriter(UploadStore* store, UploadSession session, fs::path temp, fs::path final_path,
                                      std::int64_t length, std::FILE* file)
    : store_(store), session_(std::move(session)), temp_(std::move(temp)), final_(std::move(final_path)),
      length_(length), file_(file) {}

UploadStore::ImageWriter::ImageWriter(ImageWriter&& other) noexcept
    : store_(other.store_), session_(std::move(other.session_)), temp_(std::move(other.temp_)),
      final_(std::move(other.final_)), length_(other.length_), file_(other.file_), received_(other.received_),
      too_large_(other.too_large_), error_number_(other.error_number_), stored_(other.stored_) {
  other.store_ = nullptr;
  other.file_ = nullptr;
}

UploadStore::ImageWriter::~ImageWriter() {
  if (store_ == nullptr) return;
  if (file_ != nullptr) std::fclose(file_);
  if (!stored_) RemoveQuietly(temp_);
  store_->Release(session_.id);
}

bool UploadStore::ImageWriter::Write(const char* data, std::size_t size) {
  if (file_ == nullptr || error_number_ != 0) return false;
  if (received_ + static_cast<std::int64_t>(size) > length_) {
    too_large_ = true;
    return false;
  }
  if (std::fwrite(data, 1, size, file_) != size) {
    error_number_ = errno != 0 ? errno : EIO;
    return false;
  }
  received_ += static_cast<std::int64_t>(size);
  return true;
}

UploadSession UploadStore::ImageWriter::Finish() {
  bool ok = std::fflush(file_) == 0 && ::fsync(fileno(file_)) == 0;
  if (!ok && error_number_ == 0) error_number_ = errno;
  std::fclose(file_);
  file_ = nullptr;
  const std::string name = final_.filename().string();
  if (error_number_ != 0) ThrowStorageError(error_number_, fmt::format("image \"{}\" was not stored", name));
  if (received_ != length_) {
    throw ApiError(400, "bad_upload",
                   fmt::format("image \"{}\": {} of its {} bytes arrived; it was not stored, send it again", name,
                               received_, length_));
  }
  std::error_code ec;
  fs::rename(temp_, final_, ec);
  if (ec) throw EnvironmentError(fmt::format("cannot store image \"{}\": {}", name, ec.message()));
  stored_ = true;
  // The rename is durable once the folder is synced.
  const int folder = ::open(final_.parent_path().c_str(), O_RDONLY | O_DIRECTORY);
  if (folder >= 0) {
    ::fsync(folder);
    ::close(folder);
  }
  // The set now: this image in place of one of its name (the writer held the set: nothing
  // else changed it).
  std::vector<StoredImage>& images = session_.images;
  const auto at = std::lower_bound(images.begin(), images.end(), name,
                                   [](const StoredImage& i, const std::string& n) { return i.name < n; });
  if (at != images.end() && at->name == name) {
    session_.offset -= at->size;
    at->size = length_;
  } else {
    images.insert(at, StoredImage{name, length_});
  }
  session_.offset += length_;
  session_.updated_ms = NowMs();
  store_->ImageStored(session_.id, StoredImage{name, length_});
  return session_;
}

}  // namespace glam::api
