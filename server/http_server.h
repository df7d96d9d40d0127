// `glam serve`'s HTTP layer: cpp-httplib glue around api::JobService and nothing else. Routes
// are declared once in a table (Routes()) that both registers the handlers and lets a test
// check that api/openapi.yaml documents every one of them.
//
// Threads: cpp-httplib's default pool has max(8, cores-1) workers and every open SSE stream or
// kept-alive connection holds one, so the pool is replaced by a bigger one (http_threads) and
// SSE streams are bounded (max_sse_clients, 503 beyond). Uploads stream to disk chunk by chunk
// (never held in memory) and are bounded in size and number.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "api/job_service.h"
#include "server/http_metrics.h"

namespace httplib {
class Server;
struct Request;
struct Response;
}  // namespace httplib

namespace glam::server {

struct HttpServerOptions {
  std::string bind = "127.0.0.1";
  int port = 8080;  // 0 = any free port (see HttpServer::Bind)
  // When non-empty, every /api/v1 request except health and openapi.yaml needs
  // "Authorization: Bearer <token>" (or ?token=<token>, for EventSource which cannot set headers).
  std::string token;
  std::int64_t max_upload_bytes = 8LL << 30;
  int max_concurrent_uploads = 16;
  // Resumable uploads (POST /api/v1/uploads, api/upload_store.h): sessions open at once, and
  // how long one is kept after its last byte arrived.
  int max_open_uploads = 64;
  std::chrono::seconds upload_expiry = std::chrono::hours(24);
  // How often expired sessions are removed while the server runs (also at start and whenever
  // a session is opened): an abandoned multi-GB upload frees its disk within this much of its
  // expiry even when nobody uploads.
  std::chrono::milliseconds upload_sweep_interval = std::chrono::minutes(10);
  int http_threads = 64;
  int max_sse_clients = 32;
  std::string cors_origin;          // empty: no CORS headers
  std::filesystem::path web_root;   // static viewer; empty or missing: built-in index page
  int read_timeout_s = 30;
  int write_timeout_s = 30;
  std::chrono::seconds sse_keepalive{15};

  void Check() const;  // throws InputError
};

// One REST route: method and OpenAPI path template ("/api/v1/jobs/{id}").
struct RouteInfo {
  std::string method;
  std::string path;
};

class HttpServer {
 public:
  HttpServer(api::JobService& service, HttpServerOptions options);
  ~HttpServer();
  HttpServer(const HttpServer&) = delete;
  HttpServer& operator=(const HttpServer&) = delete;

  // Binds the listening socket; returns the port (the chosen one when options.port == 0).
  // Throws EnvironmentError if the address cannot be bound.
  int Bind();
  // Serves until Stop(); returns after the worker pool has drained.
  void Run();
  // Stops accepting; safe from any thread.
  void Stop();

  static const std::vector<RouteInfo>& Routes();

  // State shared by the handlers (defined in http_server.cc).
  struct Context;

 private:
  std::unique_ptr<Context> context_;
  std::unique_ptr<httplib::Server> server_;
};

}  // namespace glam::server
