// Internal to server/: what every HTTP handler shares, and the handler entry points that
// http_server.cc wires into the route table. Handlers throw api::ApiError (or InputError) for
// client errors; the route wrapper turns them into JSON error bodies.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>

// Engine headers (Eigen) must come before httplib.h: it pulls in <resolv.h>, whose macros
// break Eigen's product kernels when Eigen is parsed afterwards.
#include "api/job_service.h"
#include "api/upload_store.h"
#include "server/http_metrics.h"
#include "server/http_server.h"

#include <httplib.h>
#include <nlohmann/json.hpp>

namespace glam::server {

struct HttpServer::Context {
  Context(api::JobService& s, HttpServerOptions o)
      : service(s), options(std::move(o)), uploads(ResumableUploadOptions(s, options)) {}
  // DIR/resumable beside the job store, with the server's upload limits.
  static api::UploadStoreOptions ResumableUploadOptions(const api::JobService& s, const HttpServerOptions& o) {
    api::UploadStoreOptions u;
    u.dir = s.data_dir() / "resumable";
    u.max_bytes = o.max_upload_bytes;
    u.max_sessions = o.max_open_uploads;
    u.expiry = o.upload_expiry;
    return u;
  }
  api::JobService& service;
  HttpServerOptions options;
  api::UploadStore uploads;
  HttpMetrics metrics;
  std::atomic<int> sse_clients{0};
  std::atomic<int> uploads_in_progress{0};
  std::chrono::steady_clock::time_point started = std::chrono::steady_clock::now();
  // The expiry sweep of resumable uploads while Run() serves.
  std::mutex sweep_mutex;
  std::condition_variable sweep_wake;
  bool sweep_stop = false;
};
using Context = HttpServer::Context;

void SendJson(httplib::Response& res, int status, const nlohmann::json& body);
void SendError(httplib::Response& res, int status, const std::string& code,
               const std::string& message);
// The job id captured by the route regex (validated by the service).
std::string JobIdParam(const httplib::Request& req);

// Reads and discards the rest of a rejected request body (up to 64 MiB, else the connection
// is closed) so that a client that sends the whole body before reading sees the status.
void DrainRejectedBody(const httplib::Request& req, httplib::Response& res,
                       const httplib::ContentReader& reader);

// POST /api/v1/jobs (multipart/form-data or a raw video body).
void HandleCreateJob(Context& ctx, const httplib::Request& req, httplib::Response& res,
                     const httplib::ContentReader& reader);
// Reads a small JSON request body (at most max_bytes: 413 beyond) and parses it (400 unless it
// is a JSON object).
nlohmann::json ReadJsonObjectBody(httplib::Response& res, const httplib::ContentReader& reader,
                                  std::size_t max_bytes, const char* what);
// POST /api/v1/jobs with an application/json body: {"upload_id"} (a completed resumable
// upload) or {"stream_url"} (a live stream).
void HandleCreateJobFromJson(Context& ctx, httplib::Response& res, const httplib::ContentReader& reader);
// POST /api/v1/uploads, GET | DELETE /api/v1/uploads/{id}, PATCH /api/v1/uploads/{id}.
void HandleCreateUpload(Context& ctx, const httplib::Request& req, httplib::Response& res,
                        const httplib::ContentReader& reader);
void HandleGetUpload(Context& ctx, const httplib::Request& req, httplib::Response& res);
void HandleDeleteUpload(Context& ctx, const httplib::Request& req, httplib::Response& res);
void HandleAppendUpload(Context& ctx, const httplib::Request& req, httplib::Response& res,
                        const httplib::ContentReader& reader);
// PUT /api/v1/uploads/{id}/images/{name}: one whole photo of an image set.
void HandlePutUploadImage(Context& ctx, const httplib::Request& req, httplib::Response& res,
                          const httplib::ContentReader& reader);
// Counts a request that receives upload bytes against max_concurrent_uploads (503 beyond).
class UploadSlot {
 public:
  explicit UploadSlot(Context& ctx);
  ~UploadSlot();
  UploadSlot(const UploadSlot&) = delete;
  UploadSlot& operator=(const UploadSlot&) = delete;

 private:
  Context& ctx_;
};

// GET /api/v1/jobs/{id}/events (Server-Sent Events).
void HandleEvents(Context& ctx, const httplib::Request& req, httplib::Response& res);
// GET /api/v1/jobs/{id}/<file>: ETag / If-None-Match and Range support.
void HandleDownload(Context& ctx, const httplib::Request& req, httplib::Response& res,
                    const std::string& file_name);

}  // namespace glam::server
