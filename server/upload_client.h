// The client side of a GLAM server's REST API, for `glam upload` (server/cli_upload.cc): sends
// a video (and its GPS track) as resumable uploads, or a folder of photos as a resumable image
// set (docs/api.md, "Resumable uploads"), makes a job of them, follows it and downloads its
// results.
//
// Why a client in the server's binary: a field team uploads multi-GB videos over mobile links
// from the laptop that also runs `glam map` offline; curl cannot resume by itself. A chunk that
// fails (connection lost, timeout, server restarting, 5xx, 503 limits) is retried with
// exponential backoff after asking the server for its offset (or its photos), so the bytes it
// already has are never sent twice; a request the server refuses (other 4xx) is not retried. The server's
// errors arrive as api::ApiError, the type it threw them as.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "api/api_error.h"

namespace httplib {
class Client;
}

namespace glam::cli {

struct UploadClientOptions {
  // http(s)://host[:port][/path prefix] of the server (the prefix when it sits behind a proxy).
  std::string server = "http://127.0.0.1:8080";
  std::string token;  // Bearer token; empty = none
  std::int64_t chunk_bytes = 16LL << 20;
  // Consecutive failures of one chunk before giving up (the upload stays on the server).
  int max_attempts = 8;
  std::chrono::milliseconds first_backoff{1000};  // doubled after every failure ...
  std::chrono::milliseconds max_backoff{30000};   // ... up to this
  std::chrono::seconds request_timeout{300};      // per socket read / write

  void Check() const;  // throws InputError
};

struct UploadProgress {
  std::int64_t offset = 0;  // bytes the server has (plus those of the chunk in flight)
  std::int64_t size = 0;
  std::string retry;  // why the last chunk (or photo) is being retried; empty while all goes well
};

class UploadClient {
 public:
  explicit UploadClient(UploadClientOptions options);  // throws InputError for a bad server URL
  ~UploadClient();
  UploadClient(const UploadClient&) = delete;
  UploadClient& operator=(const UploadClient&) = delete;

  // Sends `file` as a resumable upload and returns its id; continues `upload_id` (from the
  // offset the server has) when given. `progress` is called after every chunk and retry.
  // Throws api::ApiError (the server's status and error code) for a refusal, EnvironmentError
  // when the server stayed unreachable or failing for
  // max_attempts tries (the message names the upload id to continue with).
  std::string UploadFile(const std::filesystem::path& file, const std::string& upload_id,
                         const std::function<void(const UploadProgress&)>& progress);

  // Sends `photos` as a resumable image set (one whole photo per request, named by
  // api::SafeImageName of its file name; `name`: the set's, the job's display name) and
  // returns its id; continues `upload_id` when given, sending only the photos it lacks.
  // `progress` is called after every photo and retry. Throws InputError when two photos would
  // share a name or one is not named like an image; else as UploadFile.
  std::string UploadImages(const std::vector<std::filesystem::path>& photos, const std::string& name,
                           const std::string& upload_id, const std::function<void(const UploadProgress&)>& progress);

  // POST /jobs {"upload_id", "telemetry_upload_id" (if not empty), "options"}: the job JSON.
  nlohmann::json CreateJob(const std::string& upload_id, const std::string& telemetry_upload_id,
                           const nlohmann::json& options);
  nlohmann::json GetJob(const std::string& job_id);
  // GET /jobs/{id}/{name} into `destination` (written to a temporary name, then renamed).
  void Download(const std::string& job_id, const std::string& name, const std::filesystem::path& destination);

  // The URL of `path` (e.g. "/?job=<id>", the viewer) on the server.
  std::string UrlOf(const std::string& path) const;

 private:
  nlohmann::json GetUpload(const std::string& upload_id);
  // POST /uploads; the new upload's JSON.
  nlohmann::json OpenUpload(const nlohmann::json& request);
  // Calls `send` (one request) until it returns: a refusal (a 4xx that cannot change) is
  // thrown; any other failure is retried after a backoff and `recover` (which reads the
  // server's state again; a refusal there is thrown too), up to max_attempts in a row, each
  // reported through `on_retry`; then EnvironmentError with `give_up(failure, tries)`.
  void WithRetries(const std::function<void()>& send, const std::function<void()>& recover,
                   const std::function<void(const std::string&)>& on_retry,
                   const std::function<std::string(const std::string&, int)>& give_up);

  UploadClientOptions options_;
  std::string origin_;  // scheme://host:port
  std::string prefix_;  // path prefix without a trailing '/'
  std::unique_ptr<httplib::Client> http_;
};

}  // namespace glam::cli
