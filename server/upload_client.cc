#include "server/upload_client.h"

#include <algorithm>
#include <fstream>
#include <regex>
#include <thread>

#include <fmt/format.h>

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

std::string UploadClient::OpenUpload(std::int64_t size, const std::string& filename) {
  const json body = {{"size", size}, {"filename", filename}};
  const json upload = JsonOf(http_->Post(prefix_ + "/api/v1/uploads", body.dump(), "application/json"), 201,
                             "opening the upload");
  return upload.at("id").get<std::string>();
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
    id = OpenUpload(size, file.filename().string());
    GLAM_LOG_INFO("upload {} opened for {} ({} bytes)", id, file.string(), size);
  } else {
    const json upload = GetUpload(id);
    if (upload.value("size", std::int64_t{-1}) != size) {
      throw InputError(fmt::format("upload {} was opened for {} bytes, {} has {}", id,
                                   upload.value("size", std::int64_t{-1}), file.string(), size));
    }
    offset = upload.value("offset", std::int64_t{0});
    GLAM_LOG_INFO("continuing upload {} at byte {} of {}", id, offset, size);
  }
  UploadProgress state{offset, size, ""};
  if (progress) progress(state);

  std::string chunk;
  int failures = 0;
  auto backoff = options_.first_backoff;
  while (offset < size) {
    const std::int64_t n = std::min(options_.chunk_bytes, size - offset);
    chunk.resize(static_cast<std::size_t>(n));
    in.clear();
    in.seekg(offset);
    if (!in.read(chunk.data(), n)) throw EnvironmentError(fmt::format("cannot read {} at byte {}", file.string(), offset));
    std::string failure;
    try {
      const json upload = JsonOf(http_->Patch(prefix_ + "/api/v1/uploads/" + id,
                                              {{"Upload-Offset", std::to_string(offset)}}, chunk,
                                              "application/offset+octet-stream"),
                                 200, "sending bytes " + std::to_string(offset) + "+");
      offset = upload.at("offset").get<std::int64_t>();
      failures = 0;
      backoff = options_.first_backoff;
      state = {offset, size, ""};
      if (progress) progress(state);
      continue;
    } catch (const api::ApiError& e) {
      if (!Transient(e)) throw;
      failure = e.what();
    } catch (const EnvironmentError& e) {
      failure = e.what();
    }
    if (++failures >= options_.max_attempts) {
      throw EnvironmentError(fmt::format("{} (gave up after {} tries; the server keeps the {} bytes it has of "
                                         "upload {}: continue with --upload-id {})",
                                         failure, failures, offset, id, id));
    }
    GLAM_LOG_WARN("{}; retrying in {:.1f} s", failure, backoff.count() / 1000.0);
    state.retry = failure;
    if (progress) progress(state);
    std::this_thread::sleep_for(backoff);
    backoff = std::min(options_.max_backoff, backoff * 2);
    try {
      offset = GetUpload(id).at("offset").get<std::int64_t>();  // what arrived of the failed chunk stays
    } catch (const api::ApiError& e) {
      if (!Transient(e)) throw;  // gone (expired, deleted)
    } catch (const EnvironmentError&) {
      // Still unreachable: the next PATCH tries again from the last known offset.
    }
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
