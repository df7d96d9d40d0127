// POST /api/v1/jobs: the body streams to DIR/uploads/<random>.part in chunks as it arrives
// (never held in memory), the size limit is enforced while streaming, and only a complete,
// probed file becomes a job. Every failure path removes the partial file.
//
// A photo job sends multipart fields "images" instead of "video" (one file each, e.g. a DJI
// survey's JPEGs): they stream into a folder DIR/uploads/<random>.part/ under names the server
// makes from the client's (directories and odd characters stripped, so "../../x.jpg" is
// "x.jpg" inside the folder), the size limit counts them all, and the folder becomes the job's
// input, mapped like `glam map FOLDER`.
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <set>

#include <fmt/format.h>

#include "api/api_error.h"
#include "api/image_names.h"
#include "api/job_json.h"
#include "engine/geo/gps_track.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "server/http_context.h"

namespace glam::server {
namespace {

namespace fs = std::filesystem;
using api::ApiError;

constexpr std::size_t kMaxOptionsBytes = 64 * 1024;
// A DJI .SRT has ~250 bytes per frame: 64 MiB holds ~2.5 hours of 30 fps telemetry.
constexpr std::size_t kMaxTelemetryBytes = 64u << 20;

// The temporary upload file; removed unless Release()d (ownership passes to the service).
class TempUpload {
 public:
  explicit TempUpload(fs::path path) : path_(std::move(path)) {
    file_ = std::fopen(path_.c_str(), "wb");
    if (file_ == nullptr) {
      throw EnvironmentError(fmt::format("cannot create {}: {}", path_.string(), std::strerror(errno)));
    }
  }
  ~TempUpload() {
    Close();
    if (!released_) {
      std::error_code ec;
      fs::remove(path_, ec);
    }
  }
  TempUpload(const TempUpload&) = delete;
  TempUpload& operator=(const TempUpload&) = delete;

  // False on a write error; error_number() tells which.
  bool Write(const char* data, std::size_t size) {
    if (std::fwrite(data, 1, size, file_) != size) {
      write_errno_ = errno;
      return false;
    }
    bytes_ += static_cast<std::int64_t>(size);
    return true;
  }
  bool Close() {
    if (file_ == nullptr) return write_errno_ == 0;
    const bool ok = std::fflush(file_) == 0 && ::fsync(fileno(file_)) == 0;
    if (!ok && write_errno_ == 0) write_errno_ = errno;
    std::fclose(file_);
    file_ = nullptr;
    return ok && write_errno_ == 0;
  }
  const fs::path& Release() {
    released_ = true;
    return path_;
  }
  std::int64_t bytes() const { return bytes_; }
  int error_number() const { return write_errno_; }

 private:
  fs::path path_;
  std::FILE* file_ = nullptr;
  std::int64_t bytes_ = 0;
  int write_errno_ = 0;
  bool released_ = false;
};

// The folder of a photo upload; removed with everything in it unless Release()d.
class TempFolder {
 public:
  explicit TempFolder(fs::path path) : path_(std::move(path)) {
    std::error_code ec;
    fs::create_directories(path_, ec);
    if (ec) throw EnvironmentError(fmt::format("cannot create {}: {}", path_.string(), ec.message()));
  }
  ~TempFolder() {
    if (released_) return;
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;
  const fs::path& path() const { return path_; }
  const fs::path& Release() {
    released_ = true;
    return path_;
  }

 private:
  fs::path path_;
  bool released_ = false;
};

[[noreturn]] void ThrowWriteError(int error_number) {
  // EFBIG: the process file-size limit (RLIMIT_FSIZE) is a storage limit too.
  if (error_number == ENOSPC || error_number == EDQUOT || error_number == EFBIG) {
    throw ApiError(507, "insufficient_storage", "the server's disk is full; the upload was discarded");
  }
  throw EnvironmentError(fmt::format("cannot store the upload: {}", std::strerror(error_number)));
}

std::string ExtensionForContentType(const std::string& type) {
  if (type == "video/mp4") return "upload.mp4";
  if (type == "video/quicktime") return "upload.mov";
  if (type == "video/x-matroska" || type == "video/matroska") return "upload.mkv";
  if (type == "video/webm") return "upload.webm";
  if (type == "video/x-msvideo") return "upload.avi";
  return "upload.video";
}

// Options of a raw-body upload: X-Glam-Options (JSON) or query parameters.
api::JobOptions RawBodyOptions(const httplib::Request& req) {
  if (req.has_header("X-Glam-Options")) {
    return api::ParseJobOptionsText(req.get_header_value("X-Glam-Options"));
  }
  nlohmann::json j = nlohmann::json::object();
  for (const auto& [key, value] : req.params) {
    if (key == "token" || key == "filename") continue;
    if (key == "name") {
      j[key] = value;
    } else if (key == "rolling_shutter_ms" && value == "auto") {
      j[key] = value;
    } else if (key == "fixed_k1" || key == "refine_focal") {
      if (value == "true" || value == "1") {
        j[key] = true;
      } else if (value == "false" || value == "0") {
        j[key] = false;
      } else {
        throw InputError(fmt::format("query parameter {} must be true or false, got \"{}\"", key, value));
      }
    } else {
      try {
        std::size_t used = 0;
        if (key == "focal" || key == "smooth_window_s" || key == "rolling_shutter_ms" || key == "preview_interval_s" ||
            key == "detect_max_seconds") {
          j[key] = std::stod(value, &used);
        } else {
          j[key] = std::stoll(value, &used);
        }
        if (used != value.size()) throw std::invalid_argument(value);
      } catch (const std::exception&) {
        throw InputError(fmt::format("query parameter {} must be a number, got \"{}\"", key, value));
      }
    }
  }
  return api::ParseJobOptions(j);
}

}  // namespace

void DrainRejectedBody(const httplib::Request& req, httplib::Response& res,
                       const httplib::ContentReader& reader) {
  constexpr std::uint64_t kMaxDrain = 64ULL << 20;
  const auto length = req.get_header_value<std::uint64_t>("Content-Length");
  res.set_header("Connection", "close");
  if (length > kMaxDrain) return;
  if (req.is_multipart_form_data()) {
    reader([](const httplib::MultipartFormData&) { return true; },
           [](const char*, std::size_t) { return true; });
  } else {
    reader([](const char*, std::size_t) { return true; });
  }
}

UploadSlot::UploadSlot(Context& ctx) : ctx_(ctx) {
  if (++ctx_.uploads_in_progress > ctx_.options.max_concurrent_uploads) {
    --ctx_.uploads_in_progress;
    throw ApiError(503, "too_many_uploads",
                   fmt::format("{} uploads are already in progress; try again later",
                               ctx_.options.max_concurrent_uploads));
  }
}

UploadSlot::~UploadSlot() { --ctx_.uploads_in_progress; }

nlohmann::json ReadJsonObjectBody(httplib::Response& res, const httplib::ContentReader& reader, std::size_t max_bytes,
                                  const char* what) {
  std::string body;
  bool too_large = false;
  reader([&](const char* data, std::size_t size) {
    if (body.size() + size > max_bytes) {
      too_large = true;
      return false;
    }
    body.append(data, size);
    return true;
  });
  if (too_large) {
    res.set_header("Connection", "close");
    throw ApiError(413, "payload_too_large", fmt::format("{} is at most {} bytes", what, max_bytes));
  }
  nlohmann::json j = nlohmann::json::parse(body, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object()) throw ApiError(400, "bad_request", fmt::format("{} must be a JSON object", what));
  return j;
}

// A photo job from a complete image set: its folder becomes the job's input, as the folder of
// a multipart photo upload does.
static api::Job CreateJobFromImageSet(Context& ctx, const std::string& upload_id, const api::JobOptions& options) {
  ctx.service.CheckCanQueue();
  const fs::path folder = ctx.service.NewUploadPath();
  const api::UploadSession session = ctx.uploads.Take(upload_id, folder);
  // The set's name when the client gave one, as a multipart photo job's is its photo count.
  const std::string name = session.filename != "upload" ? session.filename
                           : session.images.size() == 1 ? session.images.front().name
                                                        : fmt::format("{} photos", session.images.size());
  return ctx.service.CreateJob(folder, name, options);
}

// A job from a complete resumable upload ({"upload_id"}) and optionally its GPS track
// ({"telemetry_upload_id"}), both consumed.
static api::Job CreateJobFromUploads(Context& ctx, const nlohmann::json& j, const api::JobOptions& options) {
  const std::string upload_id = j["upload_id"].get<std::string>();
  // Everything that can refuse the request is checked before the upload is consumed: a
  // client told 503 or 400 still has its bytes on the server.
  if (ctx.uploads.GetComplete(upload_id).kind == api::UploadKind::kImages) {
    if (j.contains("telemetry_upload_id")) {
      throw ApiError(400, "bad_telemetry",
                     "telemetry goes with a video; photos carry their GPS positions in their EXIF data");
    }
    return CreateJobFromImageSet(ctx, upload_id, options);
  }
  std::string telemetry;
  std::string telemetry_id;
  if (j.contains("telemetry_upload_id")) {
    telemetry_id = j["telemetry_upload_id"].get<std::string>();
    if (telemetry_id == upload_id) throw ApiError(400, "bad_telemetry", "the telemetry is the video's own upload");
    const fs::path file = ctx.uploads.CompleteDataFile(telemetry_id);
    if (fs::file_size(file) > kMaxTelemetryBytes) {
      throw ApiError(413, "payload_too_large",
                     fmt::format("the telemetry upload is larger than {} MiB", kMaxTelemetryBytes >> 20));
    }
    std::ifstream in(file, std::ios::binary);
    telemetry.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    try {
      ParseDjiSrt(telemetry);
    } catch (const InputError& e) {
      throw ApiError(400, "bad_telemetry", fmt::format("telemetry: {}", e.what()));
    }
  }
  ctx.service.CheckCanQueue();
  const fs::path video = ctx.service.NewUploadPath();
  const api::UploadSession session = ctx.uploads.Take(upload_id, video);
  if (!telemetry_id.empty()) {
    try {
      ctx.uploads.Remove(telemetry_id);  // its text travels with the job
    } catch (const std::exception& e) {
      GLAM_LOG_WARN("telemetry upload {} not removed: {}", telemetry_id, e.what());
    }
  }
  return ctx.service.CreateJob(video, session.filename, options, telemetry);
}

// POST /api/v1/jobs with a JSON body: {"stream_url": "...", "options": {...}} (a live stream)
// or {"upload_id": "...", "telemetry_upload_id": "...", "options": {...}} (a video sent as a
// resumable upload, api/upload_store.h, and optionally its DJI .SRT track as another one).
void HandleCreateJobFromJson(Context& ctx, httplib::Response& res, const httplib::ContentReader& reader) {
  const nlohmann::json j = ReadJsonObjectBody(res, reader, 64 * 1024, "a JSON job request");
  for (const auto& [key, value] : j.items()) {
    if (key != "stream_url" && key != "upload_id" && key != "telemetry_upload_id" && key != "options") {
      throw ApiError(400, "bad_request",
                     fmt::format("unknown field \"{}\" (stream_url or upload_id, telemetry_upload_id, options)", key));
    }
  }
  const bool stream = j.contains("stream_url");
  if (stream == j.contains("upload_id")) {
    throw ApiError(400, "bad_request", "a JSON job request names either a stream_url or an upload_id");
  }
  for (const char* key : {"stream_url", "upload_id", "telemetry_upload_id"}) {
    if (j.contains(key) && !j[key].is_string()) throw ApiError(400, "bad_request", fmt::format("{} must be a string", key));
  }
  if (stream && j.contains("telemetry_upload_id")) {
    throw ApiError(400, "bad_telemetry", "telemetry goes with an uploaded video, not a live stream");
  }
  const api::JobOptions options =
      j.contains("options") ? api::ParseJobOptions(j["options"]) : api::JobOptions{};
  api::Job job;
  if (stream) {
    job = ctx.service.CreateStreamJob(j["stream_url"].get<std::string>(), options);
  } else {
    job = CreateJobFromUploads(ctx, j, options);
  }
  res.set_header("Location", "/api/v1/jobs/" + job.id);
  SendJson(res, 201, api::JobToJson(job));
}

void HandleCreateJob(Context& ctx, const httplib::Request& req, httplib::Response& res,
                     const httplib::ContentReader& reader) {
  const std::string content_type = req.get_header_value("Content-Type");
  const std::string media_type = content_type.substr(0, content_type.find(';'));
  const bool multipart = req.is_multipart_form_data();
  const bool raw = media_type.rfind("video/", 0) == 0 || media_type == "application/octet-stream";
  if (media_type == "application/json") {
    HandleCreateJobFromJson(ctx, res, reader);
    return;
  }
  try {
    if (!multipart && !raw) {
      throw ApiError(415, "unsupported_media_type",
                     fmt::format("send the video as multipart/form-data (field \"video\", or photos as "
                                 "fields \"images\") or as a raw body with a video/* or "
                                 "application/octet-stream content type, or a live stream as "
                                 "application/json {{\"stream_url\": ...}}, not \"{}\"",
                                 content_type));
    }
    ctx.service.CheckCanQueue();
    const std::uint64_t declared = req.get_header_value<std::uint64_t>("Content-Length");
    if (!multipart && declared > static_cast<std::uint64_t>(ctx.options.max_upload_bytes)) {
      throw ApiError(413, "payload_too_large",
                     fmt::format("the upload has {} bytes; the limit is {} bytes", declared,
                                 ctx.options.max_upload_bytes));
    }
    std::error_code ec;
    const fs::space_info space = fs::space(ctx.service.data_dir(), ec);
    if (!ec && declared > 0 && declared > space.available) {
      throw ApiError(507, "insufficient_storage",
                     fmt::format("the upload has {} bytes but only {} bytes are free", declared,
                                 space.available));
    }
  } catch (const ApiError&) {
    DrainRejectedBody(req, res, reader);
    throw;
  }
  UploadSlot slot(ctx);
  TempUpload upload(ctx.service.NewUploadPath());
  bool too_large = false;
  bool write_failed = false;
  int write_errno = 0;
  std::int64_t received = 0;  // video or photo bytes so far, against max_upload_bytes
  auto receive_into = [&](TempUpload& file, const char* data, std::size_t size) {
    if (received + static_cast<std::int64_t>(size) > ctx.options.max_upload_bytes) {
      too_large = true;
      return false;
    }
    if (!file.Write(data, size)) {
      write_failed = true;
      write_errno = file.error_number();
      return false;
    }
    received += static_cast<std::int64_t>(size);
    return true;
  };
  auto receive = [&](const char* data, std::size_t size) { return receive_into(upload, data, size); };
  // A photo job: the folder and the photo being received.
  std::optional<TempFolder> photos;
  std::unique_ptr<TempUpload> photo;
  std::set<std::string> photo_names;
  auto close_photo = [&] {
    if (!photo) return true;
    const bool ok = photo->Close();
    if (!ok) {
      write_failed = true;
      write_errno = photo->error_number();
    }
    photo->Release();  // the folder removes it on failure
    photo.reset();
    return ok;
  };

  std::string original_name;
  std::string telemetry;  // multipart field "telemetry": the video's GPS track (DJI .SRT)
  api::JobOptions options;
  bool read_ok = false;
  if (multipart) {
    std::string field;
    std::string options_text;
    bool have_video = false;
    bool have_options = false;
    bool options_too_long = false;
    bool telemetry_too_long = false;
    std::string photo_error;  // why a photo part was refused
    std::string photo_storage_error;  // a photo could not be stored (server side)
    bool video_and_photos = false;
    read_ok = reader(
        [&](const httplib::MultipartFormData& part) {
          field = part.name;
          if (field == "images") {
            if (have_video) {
              video_and_photos = true;
              return false;
            }
            if (!close_photo()) return false;
            if (photo_names.size() >= api::kMaxImagesPerJob) {
              photo_error = fmt::format("more than {} images in one job", api::kMaxImagesPerJob);
              return false;
            }
            const std::string name = api::SafeImageName(part.filename);
            if (name.empty()) {
              photo_error = api::NotAnImageNameMessage(part.filename);
              return false;
            }
            if (!photo_names.insert(name).second) {
              photo_error = fmt::format("two images are named \"{}\"", name);
              return false;
            }
            // No exception may cross httplib's reader: a storage error ends the read and is
            // thrown after it.
            try {
              if (!photos) photos.emplace(ctx.service.NewUploadPath());
              photo = std::make_unique<TempUpload>(photos->path() / name);
            } catch (const EnvironmentError& e) {
              photo_storage_error = e.what();
              return false;
            }
            return true;
          }
          if (field == "video") {
            if (have_video) return false;  // one video per job
            if (photos) {
              video_and_photos = true;
              return false;
            }
            have_video = true;
            original_name = part.filename.empty() ? ExtensionForContentType(part.content_type)
                                                  : part.filename;
          } else if (field == "options") {
            have_options = true;
          } else if (field == "telemetry") {
            if (!telemetry.empty()) return false;  // one track per job
          }
          return true;
        },
        [&](const char* data, std::size_t size) {
          if (field == "video") return receive(data, size);
          if (field == "images") return receive_into(*photo, data, size);
          if (field == "options") {
            if (options_text.size() + size > kMaxOptionsBytes) {
              options_too_long = true;
              return false;
            }
            options_text.append(data, size);
          }
          if (field == "telemetry") {
            if (telemetry.size() + size > kMaxTelemetryBytes) {
              telemetry_too_long = true;
              return false;
            }
            telemetry.append(data, size);
          }
          return true;  // other fields are ignored
        });
    if (read_ok) close_photo();
    if (!photo_storage_error.empty()) {
      res.set_header("Connection", "close");
      throw EnvironmentError(photo_storage_error);
    }
    if (options_too_long) throw ApiError(400, "bad_options", "the options field is larger than 64 KiB");
    if (video_and_photos) {
      res.set_header("Connection", "close");
      throw ApiError(400, "bad_upload", "send either a \"video\" field or \"images\" fields, not both");
    }
    if (!photo_error.empty()) {
      res.set_header("Connection", "close");
      throw ApiError(400, "bad_image", photo_error);
    }
    if (telemetry_too_long) {
      res.set_header("Connection", "close");
      throw ApiError(413, "payload_too_large",
                     fmt::format("the telemetry field is larger than {} MiB", kMaxTelemetryBytes >> 20));
    }
    if (read_ok && !have_video && !photos) {
      throw ApiError(400, "missing_video", "multipart upload without a \"video\" field (or \"images\" fields)");
    }
    if (photos && !telemetry.empty()) {
      throw ApiError(400, "bad_telemetry",
                     "telemetry goes with a video; photos carry their GPS positions in their EXIF data");
    }
    if (have_options) options = api::ParseJobOptionsText(options_text);
    if (read_ok && !telemetry.empty()) {
      try {
        ParseDjiSrt(telemetry);  // refused now rather than a warning after the mapping
      } catch (const InputError& e) {
        throw ApiError(400, "bad_telemetry", fmt::format("telemetry: {}", e.what()));
      }
    }
  } else {
    options = RawBodyOptions(req);
    original_name = req.has_param("filename") ? req.get_param_value("filename")
                                              : ExtensionForContentType(media_type);
    read_ok = reader(receive);
  }
  if (too_large) {
    res.set_header("Connection", "close");
    throw ApiError(413, "payload_too_large",
                   fmt::format("the upload exceeds the limit of {} bytes", ctx.options.max_upload_bytes));
  }
  if (write_failed) {
    res.set_header("Connection", "close");
    ThrowWriteError(write_errno);
  }
  if (!read_ok) {
    res.set_header("Connection", "close");
    if (res.status == 413) {
      throw ApiError(413, "payload_too_large",
                     fmt::format("the upload exceeds the limit of {} bytes", ctx.options.max_upload_bytes));
    }
    throw ApiError(400, "bad_upload", "the request body could not be read completely");
  }
  if (photos) {
    GLAM_LOG_DEBUG("upload of {} photos, {} bytes received", photo_names.size(), received);
    const std::string display_name =
        photo_names.size() == 1 ? *photo_names.begin() : fmt::format("{} photos", photo_names.size());
    const api::Job job = ctx.service.CreateJob(photos->Release(), display_name, options);
    res.set_header("Location", "/api/v1/jobs/" + job.id);
    SendJson(res, 201, api::JobToJson(job));
    return;
  }
  if (!upload.Close()) ThrowWriteError(upload.error_number());
  if (upload.bytes() == 0) throw ApiError(400, "empty_body", "the uploaded video is empty");
  GLAM_LOG_DEBUG("upload of {} bytes received", upload.bytes());
  const api::Job job = ctx.service.CreateJob(upload.Release(), original_name, options, telemetry);
  res.set_header("Location", "/api/v1/jobs/" + job.id);
  SendJson(res, 201, api::JobToJson(job));
}

}  // namespace glam::server
