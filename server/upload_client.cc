#include "server/upload_client.h"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <map>
#include <regex>
#include <thread>

#include <fmt/format.h>

#include "api/image_names.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"

#include <httplib.h>

namespace glam::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// The server's JSON error, or the status line when the body is not one.
api::ApiError ErrorOf(const httplib::Result& res, const std::string& what) {
  const json body = json::parse(res->body, nullptr, /*allow_exceptions=*/false);
  if (body.is_object() && body.contains("error") && body["error"].is_object()) {
    const std::string code = body["error"].value("code", "error");
    return api::ApiError(res->status, code,
                       fmt::format("{}: {} ({} {})", what, body["error"].value("message", ""), res->status, code));
  }
  return api::ApiError(res->status, "error", fmt::format("{}: HTTP {}", what, res->status));
}

// Answers worth retrying: the request may succeed later as it is.
bool Transient(const api::ApiError& e) {
  return e.status() >= 500 || e.status() == 408 || e.status() == 429 || e.code() == "upload_busy" ||
         e.code() == "offset_mismatch";
}

json JsonOf(const httplib::Result& res, int expected, const std::string& what) {
  if (!res) {
    throw EnvironmentError(fmt::format("{}: cannot reach the server ({})", what, httplib::to_string(res.error())));
  }
  if (res->status != expected) throw ErrorOf(res, what);
  json body = json::parse(res->body, nullptr, /*allow_exceptions=*/false);
  if (!body.is_object()) throw EnvironmentError(fmt::format("{}: the server's answer is not JSON", what));
  return body;
}

}  // namespace

void UploadClientOptions::Check() const {
  if (chunk_bytes < 1024) throw InputError(fmt::format("the chunk size must be at least 1 KiB, got {} bytes", chunk_bytes));
  if (max_attempts < 1) throw InputError(fmt::format("--retries must be at least 1, got {}", max_attempts));
  if (first_backoff.count() < 0 || max_backoff < first_backoff) throw InputError("bad retry backoff");
  if (request_timeout.count() < 1) throw InputError("the request timeout must be at least 1 s");
}

UploadClient::UploadClient(UploadClientOptions options) : options_(std::move(options)) {
  options_.Check();
  static const std::regex kUrl(R"(^(https?://[^/?#]+)(/[^?#]*)?$)");
  std::smatch m;
  if (!std::regex_match(options_.server, m, kUrl)) {
    throw InputError(fmt::format("--server must be an http:// or https:// URL such as http://127.0.0.1:8080, got \"{}\"",
                                 options_.server));
  }
  origin_ = m[1];
  prefix_ = m[2];
  while (!prefix_.empty() && prefix_.back() == '/') prefix_.pop_back();
  http_ = std::make_unique<httplib::Client>(origin_);
  if (!http_->is_valid()) throw InputError(fmt::format("cannot use the server URL {}", options_.server));
  const auto timeout = static_cast<time_t>(options_.request_timeout.count());
  http_->set_connection_timeout(10, 0);
  http_->set_read_timeout(timeout, 0);
  http_->set_write_timeout(timeout, 0);
  http_->set_keep_alive(true);
  if (!options_.token.empty()) http_->set_bearer_token_auth(options_.token);
}

UploadClient::~UploadClient() = default;

std::string UploadClient::UrlOf(const std::string& path) const { return origin_ + prefix_ + path; }

json UploadClient::GetUpload(const std::string& upload_id) {
  return JsonOf(http_->Get(prefix_ + "/api/v1/uploads/" + upload_id), 200, "upload " + upload_id);
}

json UploadClient::OpenUpload(const json& request) {
  return JsonOf(http_->Post(prefix_ + "/api/v1/uploads", request.dump(), "application/json"), 201,
                "opening the upload");
}

void UploadClient::WithRetries(const std::function<void()>& send, const std::function<void()>& recover,
                               const std::function<void(const std::string&)>& on_retry,
                               const std::function<std::string(const std::string&, int)>& give_up) {
  auto backoff = options_.first_backoff;
  for (int failures = 0;;) {
    std::string failure;
    try {
      send();
      return;
    } catch (const api::ApiError& e) {
      if (!Transient(e)) throw;
      failure = e.what();
    } catch (const EnvironmentError& e) {
      failure = e.what();
    }
    if (++failures >= options_.max_attempts) throw EnvironmentError(give_up(failure, failures));
    GLAM_LOG_WARN("{}; retrying in {:.1f} s", failure, backoff.count() / 1000.0);
    on_retry(failure);
    std::this_thread::sleep_for(backoff);
    backoff = std::min(options_.max_backoff, backoff * 2);
    try {
      recover();
    } catch (const api::ApiError& e) {
      if (!Transient(e)) throw;  // gone (expired, deleted)
    } catch (const EnvironmentError&) {
      // Still unreachable: the next try starts from what was last known.
    }
  }
}

std::string UploadClient::UploadFile(const fs::path& file, const std::string& upload_id,
                                     const std::function<void(const UploadProgress&)>& progress) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw InputError(fmt::format("cannot read {}", file.string()));
  std::error_code ec;
  const auto size = static_cast<std::int64_t>(fs::file_size(file, ec));
  if (ec || size == 0) throw InputError(fmt::format("{} is empty or unreadable", file.string()));

  std::string id = upload_id;
  std::int64_t offset = 0;
  if (id.empty()) {
    id = OpenUpload({{"size", size}, {"filename", file.filename().string()}}).at("id").get<std::string>();
    GLAM_LOG_INFO("upload {} opened for {} ({} bytes)", id, file.string(), size);
  } else {
    const json upload = GetUpload(id);
    if (upload.value("kind", "file") != "file" || upload.value("size", std::int64_t{-1}) != size) {
      throw InputError(fmt::format("upload {} was opened for {} bytes{}, {} has {}", id,
                                   upload.value("size", std::int64_t{-1}),
                                   upload.value("kind", "file") != "file" ? " of photos" : "", file.string(), size));
    }
    offset = upload.value("offset", std::int64_t{0});
    GLAM_LOG_INFO("continuing upload {} at byte {} of {}", id, offset, size);
  }
  UploadProgress state{offset, size, ""};
  if (progress) progress(state);

  std::string chunk;
  // A file that shrinks while it is sent: not retried, and an EnvironmentError (exit 3) like
  // any failure of the machine mid-run, not an InputError (the file was fine when checked).
  std::string read_failure;
  // One chunk from the offset the server has (re-read after a failure: it keeps the bytes of
  // a broken chunk).
  const auto send = [&] {
    if (offset >= size) return;
    const std::int64_t n = std::min(options_.chunk_bytes, size - offset);
    chunk.resize(static_cast<std::size_t>(n));
    in.clear();
    in.seekg(offset);
    if (!in.read(chunk.data(), n)) {
      read_failure = fmt::format("cannot read {} at byte {}", file.string(), offset);
      return;
    }
    const json upload = JsonOf(http_->Patch(prefix_ + "/api/v1/uploads/" + id,
                                            {{"Upload-Offset", std::to_string(offset)}}, chunk,
                                            "application/offset+octet-stream"),
                               200, "sending bytes " + std::to_string(offset) + "+");
    offset = upload.at("offset").get<std::int64_t>();
  };
  while (offset < size) {
    WithRetries(
        send, [&] { offset = GetUpload(id).at("offset").get<std::int64_t>(); },
        [&](const std::string& failure) {
          state.retry = failure;
          if (progress) progress(state);
        },
        [&](const std::string& failure, int tries) {
          return fmt::format("{} (gave up after {} tries; the server keeps the {} bytes it has of upload {}: "
                             "continue with --upload-id {})",
                             failure, tries, offset, id, id);
        });
    if (!read_failure.empty()) throw EnvironmentError(read_failure);
    state = {offset, size, ""};
    if (progress) progress(state);
  }
  return id;
}

namespace {

// The Content-Type of a photo, by its extension.
std::string ImageContentType(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".jpg" || ext == ".jpeg") return "image/jpeg";
  if (ext == ".png") return "image/png";
  if (ext == ".tif" || ext == ".tiff") return "image/tiff";
  if (ext == ".webp") return "image/webp";
  if (ext == ".bmp") return "image/bmp";
  return "application/octet-stream";
}

// An image set's stored photos: name -> size.
std::map<std::string, std::int64_t> StoredImages(const json& set) {
  std::map<std::string, std::int64_t> stored;
  if (!set.contains("images") || !set["images"].is_array()) return stored;
  for (const json& image : set["images"]) {
    stored[image.value("name", "")] = image.value("size", std::int64_t{-1});
  }
  return stored;
}

}  // namespace

std::string UploadClient::UploadImages(const std::vector<fs::path>& photos, const std::string& name,
                                       const std::string& upload_id,
                                       const std::function<void(const UploadProgress&)>& progress) {
  if (photos.empty()) throw InputError("no photos to send");
  std::vector<std::string> names;
  std::vector<std::int64_t> sizes;
  std::map<std::string, fs::path> by_name;
  std::int64_t total = 0;
  for (const fs::path& photo : photos) {
    const std::string clean = api::SafeImageName(photo.filename().string());
    if (clean.empty()) throw InputError(api::NotAnImageNameMessage(photo.string()));
    const auto [it, fresh] = by_name.emplace(clean, photo);
    if (!fresh) {
      throw InputError(fmt::format("{} and {} would both be sent as {}", it->second.string(), photo.string(), clean));
    }
    std::error_code ec;
    const auto size = static_cast<std::int64_t>(fs::file_size(photo, ec));
    if (ec || size == 0) throw InputError(fmt::format("{} is empty or unreadable", photo.string()));
    names.push_back(clean);
    sizes.push_back(size);
    total += size;
  }
  json set;
  if (upload_id.empty()) {
    set = OpenUpload({{"kind", "images"}, {"size", total}, {"filename", name}});
    GLAM_LOG_INFO("image set {} opened for {} photos ({} bytes)", set.at("id").get<std::string>(), photos.size(),
                  total);
  } else {
    set = GetUpload(upload_id);
    if (set.value("kind", "file") != "images" || set.value("size", std::int64_t{-1}) != total) {
      throw InputError(fmt::format("upload {} is not an image set of these {} photos ({} bytes)", upload_id,
                                   photos.size(), total));
    }
  }
  const std::string id = set.at("id").get<std::string>();
  std::map<std::string, std::int64_t> stored = StoredImages(set);
  const auto has = [&](std::size_t i) {
    const auto it = stored.find(names[i]);
    return it != stored.end() && it->second == sizes[i];
  };
  UploadProgress state{0, total, ""};
  for (std::size_t i = 0; i < photos.size(); ++i) state.offset += has(i) ? sizes[i] : 0;
  if (!upload_id.empty()) GLAM_LOG_INFO("continuing image set {}: {} of {} bytes there", id, state.offset, total);
  if (progress) progress(state);

  std::string bytes;
  for (std::size_t i = 0; i < photos.size(); ++i) {
    if (has(i)) continue;
    std::ifstream in(photos[i], std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    if (static_cast<std::int64_t>(bytes.size()) != sizes[i]) {
      throw InputError(fmt::format("cannot read {} (or it changed while sending)", photos[i].string()));
    }
    WithRetries(
        [&] {
          if (has(i)) return;  // stored: only the answer to the last try was lost
          JsonOf(http_->Put(prefix_ + "/api/v1/uploads/" + id + "/images/" + names[i], bytes,
                            ImageContentType(photos[i]).c_str()),
                 200, "sending " + photos[i].filename().string());
          stored[names[i]] = sizes[i];
        },
        [&] { stored = StoredImages(GetUpload(id)); },
        [&](const std::string& failure) {
          state.retry = failure;
          if (progress) progress(state);
        },
        [&](const std::string& failure, int tries) {
          return fmt::format("{} (gave up after {} tries; the server keeps the {} photos image set {} has: "
                             "continue with --upload-id {})",
                             failure, tries, stored.size(), id, id);
        });
    state.offset += sizes[i];
    state.retry.clear();
    if (progress) progress(state);
  }
  return id;
}

json UploadClient::CreateJob(const std::string& upload_id, const std::string& telemetry_upload_id,
                             const json& options) {
  json body = {{"upload_id", upload_id}};
  if (!telemetry_upload_id.empty()) body["telemetry_upload_id"] = telemetry_upload_id;
  if (!options.empty()) body["options"] = options;
  return JsonOf(http_->Post(prefix_ + "/api/v1/jobs", body.dump(), "application/json"), 201, "creating the job");
}

json UploadClient::GetJob(const std::string& job_id) {
  return JsonOf(http_->Get(prefix_ + "/api/v1/jobs/" + job_id), 200, "job " + job_id);
}

void UploadClient::Download(const std::string& job_id, const std::string& name, const fs::path& destination) {
  const fs::path partial = destination.string() + ".part";
  std::ofstream out(partial, std::ios::binary);
  if (!out) throw EnvironmentError(fmt::format("cannot write {}", partial.string()));
  int status = 0;
  std::string error_body;  // a refusal's JSON, not the file
  auto res = http_->Get(
      prefix_ + "/api/v1/jobs/" + job_id + "/" + name,
      [&](const httplib::Response& response) {
        status = response.status;
        return true;
      },
      [&](const char* data, std::size_t n) {
        if (status != 200) {
          error_body.append(data, std::min<std::size_t>(n, 64 * 1024 - std::min<std::size_t>(error_body.size(), 64 * 1024)));
          return true;
        }
        out.write(data, static_cast<std::streamsize>(n));
        return static_cast<bool>(out);
      });
  out.close();
  const bool ok = res && res->status == 200 && out;
  if (!ok) {
    std::error_code ec;
    fs::remove(partial, ec);
    if (!res) throw EnvironmentError(fmt::format("{}: cannot reach the server ({})", name, httplib::to_string(res.error())));
    if (res->status != 200) {
      res->body = error_body;
      throw ErrorOf(res, "downloading " + name);
    }
    throw EnvironmentError(fmt::format("cannot write {}", destination.string()));
  }
  fs::rename(partial, destination);
}

}  // namespace glam::cli
