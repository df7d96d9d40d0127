#include "server/http_server.h"

#include <algorithm>
#include <functional>
#include <regex>
#include <thread>

#include <fmt/format.h>

#include "api/api_error.h"
#include "api/ids.h"
#include "api/job_json.h"
#include "api/openapi_spec.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "server/http_context.h"
#include "server/http_index.h"

#ifndef GLAM_VERSION
#define GLAM_VERSION "unknown"
#endif

namespace glam::server {
namespace {

namespace fs = std::filesystem;
using api::ApiError;
using httplib::Request;
using httplib::Response;

using PlainHandler = std::function<void(Context&, const Request&, Response&)>;
using ReaderHandler =
    std::function<void(Context&, const Request&, Response&, const httplib::ContentReader&)>;

struct RouteDef {
  std::string method;
  std::string path;  // OpenAPI template
  bool needs_auth;
  PlainHandler handler;
  ReaderHandler reader_handler;  // POST or PATCH with a streamed body
};

int IntParam(const Request& req, const char* name, int fallback, int max) {
  if (!req.has_param(name)) return fallback;
  long long value = 0;
  const std::string text = req.get_param_value(name);
  if (!api::ParseNonNegativeInt(text, &value) || value > max) {
    throw ApiError(400, "bad_request",
                   fmt::format("{} must be an integer in 0..{}, got \"{}\"", name, max, text));
  }
  return static_cast<int>(value);
}

void HandleHealth(Context& ctx, const Request&, Response& res) {
  const api::ServiceStats stats = ctx.service.Stats();
  nlohmann::json jobs = nlohmann::json::object();
  for (const auto& [state, count] : stats.jobs_by_state) jobs[std::string(api::ToString(state))] = count;
  std::error_code ec;
  const fs::space_info space = fs::space(ctx.service.data_dir(), ec);
  const double uptime = std::chrono::duration<double>(std::chrono::steady_clock::now() - ctx.started).count();
  SendJson(res, 200,
           {{"ok", !ctx.service.shutting_down()},
            {"version", GLAM_VERSION},
            {"jobs", jobs},
            {"disk_free_bytes", ec ? nlohmann::json(nullptr) : nlohmann::json(space.available)},
            {"uptime_s", uptime}});
}

void HandleMetrics(Context& ctx, const Request&, Response& res) {
  const api::ServiceStats stats = ctx.service.Stats();
  std::string out;
  out += "# HELP glam_jobs Jobs in the store by state.\n# TYPE glam_jobs gauge\n";
  for (const auto& [state, count] : stats.jobs_by_state) {
    out += fmt::format("glam_jobs{{state=\"{}\"}} {}\n", api::ToString(state), count);
  }
  out += "# HELP glam_frames_processed_total Frames consumed by the mapping engine since start.\n";
  out += "# TYPE glam_frames_processed_total counter\n";
  out += fmt::format("glam_frames_processed_total {}\n", stats.frames_processed_total);
  out += "# HELP glam_sse_clients Open event streams.\n# TYPE glam_sse_clients gauge\n";
  out += fmt::format("glam_sse_clients {}\n", ctx.sse_clients.load());
  out += "# HELP glam_uploads_in_progress Uploads being received.\n";
  out += "# TYPE glam_uploads_in_progress gauge\n";
  out += fmt::format("glam_uploads_in_progress {}\n", ctx.uploads_in_progress.load());
  out += "# HELP glam_resumable_uploads_open Resumable uploads open (bytes still expected or not yet made a job).\n";
  out += "# TYPE glam_resumable_uploads_open gauge\n";
  out += fmt::format("glam_resumable_uploads_open {}\n", ctx.uploads.open_sessions());
  ctx.metrics.Render(&out);
  res.status = 200;
  res.set_content(out, "text/plain; version=0.0.4");
}

void HandleList(Context& ctx, const Request& req, Response& res) {
  const int limit = IntParam(req, "limit", 20, 1000);
  const int offset = IntParam(req, "offset", 0, 1000000000);
  if (limit == 0) throw ApiError(400, "bad_request", "limit must be at least 1");
  const api::JobPage page = ctx.service.List(limit, offset);
  nlohmann::json jobs = nlohmann::json::array();
  for (const api::Job& job : page.jobs) jobs.push_back(api::JobToJson(job));
  SendJson(res, 200, {{"jobs", jobs}, {"total", page.total}, {"limit", limit}, {"offset", offset}});
}

const std::vector<RouteDef>& RouteTable() {
  static const std::vector<RouteDef> table = [] {
    std::vector<RouteDef> t;
    auto plain = [&](const char* method, const char* path, bool auth, PlainHandler h) {
      t.push_back(RouteDef{method, path, auth, std::move(h), nullptr});
    };
    plain("GET", "/api/v1/health", false, HandleHealth);
    plain("GET", "/api/v1/metrics", true, HandleMetrics);
    plain("GET", "/api/v1/openapi.yaml", false, [](Context&, const Request&, Response& res) {
      res.status = 200;
      res.set_content(std::string(api::OpenApiYaml()), "application/yaml");
    });
    plain("GET", "/api/v1/jobs", true, HandleList);
    t.push_back(RouteDef{"POST", "/api/v1/jobs", true, nullptr, HandleCreateJob});
    plain("GET", "/api/v1/jobs/{id}", true, [](Context& ctx, const Request& req, Response& res) {
      SendJson(res, 200, api::JobToJson(ctx.service.Get(JobIdParam(req))));
    });
    plain("DELETE", "/api/v1/jobs/{id}", true, [](Context& ctx, const Request& req, Response& res) {
      ctx.service.Delete(JobIdParam(req));
      res.status = 204;
    });
    plain("GET", "/api/v1/jobs/{id}/events", true, HandleEvents);
    t.push_back(RouteDef{"POST", "/api/v1/uploads", true, nullptr, HandleCreateUpload});
    plain("GET", "/api/v1/uploads/{id}", true, HandleGetUpload);
    t.push_back(RouteDef{"PATCH", "/api/v1/uploads/{id}", true, nullptr, HandleAppendUpload});
    plain("DELETE", "/api/v1/uploads/{id}", true, HandleDeleteUpload);
    t.push_back(RouteDef{"PUT", "/api/v1/uploads/{id}/images/{name}", true, nullptr, HandlePutUploadImage});
    plain("POST", "/api/v1/jobs/{id}/cancel", true, [](Context& ctx, const Request& req, Response& res) {
      SendJson(res, 200, api::JobToJson(ctx.service.Cancel(JobIdParam(req))));
    });
    plain("POST", "/api/v1/jobs/{id}/restart", true, [](Context& ctx, const Request& req, Response& res) {
      SendJson(res, 200, api::JobToJson(ctx.service.Restart(JobIdParam(req))));
    });
    plain("POST", "/api/v1/jobs/{id}/finish", true, [](Context& ctx, const Request& req, Response& res) {
      SendJson(res, 200, api::JobToJson(ctx.service.Finish(JobIdParam(req))));
    });
    for (const char* file :
         {"trajectory.tum", "trajectory.geojson", "points.ply", "report.json", "graph.json", "tileset.json", "map.glb",
          "colmap/cameras.txt", "colmap/images.txt", "colmap/points3D.txt", "tiles/{submap}.open.glb",
          "tiles/{submap}.glb", "parts/{part}/trajectory.tum", "parts/{part}/points.ply",
          "parts/{part}/colmap/cameras.txt", "parts/{part}/colmap/images.txt", "parts/{part}/colmap/points3D.txt"}) {
      const std::string name = file;
      plain("GET", ("/api/v1/jobs/{id}/" + name).c_str(), true,
            [name](Context& ctx, const Request& req, Response& res) { HandleDownload(ctx, req, res, name); });
    }
    return t;
  }();
  return table;
}

// "/api/v1/jobs/{id}/points.ply" -> "/api/v1/jobs/([^/]+)/points\.ply"
std::string PathRegex(const std::string& path) {
  std::string out;
  for (std::size_t i = 0; i < path.size(); ++i) {
    const char c = path[i];
    if (c == '{') {
      i = path.find('}', i);
      out += "([^/]+)";
    } else if (c == '.') {
      out += "\\.";
    } else {
      out += c;
    }
  }
  return out;
}

bool ConstantTimeEquals(const std::string& a, const std::string& b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  const std::size_t n = std::max(a.size(), b.size());
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    diff |= static_cast<unsigned char>(x ^ y);
  }
  return diff == 0;
}

bool Authorized(const Context& ctx, const Request& req) {
  if (ctx.options.token.empty()) return true;
  const std::string header = req.get_header_value("Authorization");
  const std::string prefix = "Bearer ";
  if (header.rfind(prefix, 0) == 0 && ConstantTimeEquals(header.substr(prefix.size()), ctx.options.token)) {
    return true;
  }
  return req.has_param("token") && ConstantTimeEquals(req.get_param_value("token"), ctx.options.token);
}

const char* ErrorCodeFor(int status) {
  switch (status) {
    case 400: return "bad_request";
    case 401: return "unauthorized";
    case 404: return "not_found";
    case 405: return "method_not_allowed";
    case 413: return "payload_too_large";
    case 414: return "uri_too_long";
    case 416: return "range_not_satisfiable";
    case 503: return "unavailable";
    default: return status >= 500 ? "internal_error" : "error";
  }
}

}  // namespace

void SendJson(Response& res, int status, const nlohmann::json& body) {
  res.status = status;
  res.set_content(body.dump(), "application/json");
}

void SendError(Response& res, int status, const std::string& code, const std::string& message) {
  SendJson(res, status, api::ErrorJson(code, message));
}

std::string JobIdParam(const Request& req) { return req.matches.size() > 1 ? std::string(req.matches[1]) : ""; }

void HttpServerOptions::Check() const {
  if (port < 0 || port > 65535) throw InputError(fmt::format("--port must be in 0..65535, got {}", port));
  if (max_upload_bytes < 1) throw InputError("--max-upload-mb must be at least 1");
  if (http_threads < 4 || http_threads > 1024) {
    throw InputError(fmt::format("--http-threads must be in 4..1024, got {}", http_threads));
  }
  if (max_sse_clients < 1 || max_sse_clients >= http_threads) {
    throw InputError(fmt::format("--max-sse-clients must be in 1..{} (below --http-threads), got {}",
                                 http_threads - 1, max_sse_clients));
  }
  if (max_concurrent_uploads < 1) throw InputError("--max-concurrent-uploads must be at least 1");
  if (max_open_uploads < 1) throw InputError("--max-open-uploads must be at least 1");
  if (upload_sweep_interval.count() < 1) throw InputError("the upload sweep interval must be positive");
  if (upload_expiry < std::chrono::minutes(1)) throw InputError("--upload-expiry-hours must be at least 1 minute");
  if (token.find_first_of(" \t\r\n") != std::string::npos) throw InputError("the API token must not contain spaces");
}

const std::vector<RouteInfo>& HttpServer::Routes() {
  static const std::vector<RouteInfo> routes = [] {
    std::vector<RouteInfo> out;
    for (const RouteDef& def : RouteTable()) out.push_back(RouteInfo{def.method, def.path});
    return out;
  }();
  return routes;
}

HttpServer::HttpServer(api::JobService& service, HttpServerOptions options)
    : context_(std::make_unique<Context>(service, std::move(options))),
      server_(std::make_unique<httplib::Server>()) {
  Context* ctx = context_.get();
  ctx->options.Check();
  const int threads = ctx->options.http_threads;
  server_->new_task_queue = [threads] { return new httplib::ThreadPool(static_cast<std::size_t>(threads)); };
  server_->set_read_timeout(ctx->options.read_timeout_s, 0);
  server_->set_write_timeout(ctx->options.write_timeout_s, 0);
  // cpp-httplib writes headers and body separately: with Nagle on, the body waits for the
  // client's delayed ACK (~40 ms per small response on keep-alive connections).
  server_->set_tcp_nodelay(true);
  server_->set_keep_alive_timeout(5);
  server_->set_keep_alive_max_count(1000);
  // Room for the multipart framing around a video of max_upload_bytes; the exact limit is
  // enforced while streaming.
  server_->set_payload_max_length(static_cast<std::size_t>(ctx->options.max_upload_bytes) + (1 << 20));

  if (!ctx->options.cors_origin.empty()) {
    server_->set_default_headers({{"Access-Control-Allow-Origin", ctx->options.cors_origin},
                                  {"Vary", "Origin"},
                                  {"Access-Control-Expose-Headers", "Location, ETag, Content-Range, Upload-Offset"}});
    server_->Options(".*", [](const Request&, Response& res) {
      res.status = 204;
      res.set_header("Access-Control-Allow-Methods", "GET, POST, PUT, PATCH, DELETE, OPTIONS");
      res.set_header("Access-Control-Allow-Headers",
                     "Authorization, Content-Type, Last-Event-ID, X-Glam-Options, Range, If-None-Match, "
                     "Upload-Offset");
      res.set_header("Access-Control-Max-Age", "600");
    });
  }

  for (const RouteDef& def : RouteTable()) {
    auto run = [ctx, def](const Request& req, Response& res, const httplib::ContentReader* reader) {
      const auto start = std::chrono::steady_clock::now();
      try {
        if (def.needs_auth && !Authorized(*ctx, req)) {
          res.set_header("WWW-Authenticate", "Bearer");
          if (reader != nullptr) DrainRejectedBody(req, res, *reader);
          throw ApiError(401, "unauthorized", "missing or wrong API token (Authorization: Bearer <token>)");
        }
        if (reader != nullptr) {
          def.reader_handler(*ctx, req, res, *reader);
        } else {
          def.handler(*ctx, req, res);
        }
      } catch (const ApiError& e) {
        SendError(res, e.status(), e.code(), e.what());
      } catch (const InputError& e) {
        SendError(res, 400, "bad_request", e.what());
      } catch (const std::exception& e) {
        GLAM_LOG_ERROR("{} {}: {}", req.method, req.path, e.what());
        SendError(res, 500, "internal_error", e.what());
      }
      if (res.status >= 300) {
        // cpp-httplib applies a request's Range to whatever body is sent, error bodies
        // included (a JSON error would arrive sliced, or as an empty 416). Ranges only
        // make sense for a successful download; the Request object is owned (non-const) by
        // cpp-httplib's connection loop, so clearing them here is sound.
        const_cast<Request&>(req).ranges.clear();
      }
      const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      ctx->metrics.Observe(def.path, def.method, res.status == -1 ? 200 : res.status, seconds);
    };
    const std::string pattern = PathRegex(def.path);
    if (def.reader_handler) {
      auto with_reader = [run](const Request& req, Response& res, const httplib::ContentReader& reader) {
        run(req, res, &reader);
      };
      if (def.method == "PATCH") {
        server_->Patch(pattern, with_reader);
      } else if (def.method == "PUT") {
        server_->Put(pattern, with_reader);
      } else {
        server_->Post(pattern, with_reader);
      }
    } else if (def.method == "GET") {
      server_->Get(pattern, [run](const Request& req, Response& res) { run(req, res, nullptr); });
    } else if (def.method == "POST") {
      server_->Post(pattern, [run](const Request& req, Response& res) { run(req, res, nullptr); });
    } else if (def.method == "DELETE") {
      server_->Delete(pattern, [run](const Request& req, Response& res) { run(req, res, nullptr); });
    }
  }

  // Static viewer (web/dist). Its file names are not content-hashed, so the browser must
  // revalidate them (cpp-httplib answers with the whole file; they are small). .wasm is mapped
  // explicitly: DRACOLoader's WebAssembly decoder needs application/wasm.
  const fs::path& web = ctx->options.web_root;
  if (!web.empty() && fs::is_regular_file(web / "index.html")) {
    server_->set_file_extension_and_mimetype_mapping("wasm", "application/wasm");
    server_->set_file_extension_and_mimetype_mapping("mjs", "text/javascript");
    server_->set_file_extension_and_mimetype_mapping("map", "application/json");
    server_->set_mount_point("/", web.string(), {{"Cache-Control", "no-cache"}});
    GLAM_LOG_INFO("serving the viewer from {}", web.string());
  } else {
    if (!web.empty()) GLAM_LOG_WARN("{} has no index.html; serving the built-in job list at /", web.string());
    server_->Get("/", [](const Request&, Response& res) { res.set_content(BuiltInIndexHtml(), "text/html; charset=utf-8"); });
  }

  server_->set_error_handler([](const Request& req, Response& res) {
    if (!res.body.empty() || res.status == 304) return;
    const std::string message = res.status == 404 ? fmt::format("no such resource: {} {}", req.method, req.path)
                                                  : fmt::format("HTTP {}", res.status);
    SendError(res, res.status, ErrorCodeFor(res.status), message);
  });
  server_->set_exception_handler([](const Request& req, Response& res, std::exception_ptr ep) {
    std::string what = "unknown error";
    try {
      std::rethrow_exception(ep);
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    GLAM_LOG_ERROR("{} {}: {}", req.method, req.path, what);
    SendError(res, 500, "internal_error", what);
  });
  server_->set_logger([](const Request& req, const Response& res) {
    GLAM_LOG_DEBUG("{} {} {} {}", req.remote_addr, req.method, req.path, res.status);
  });
}

HttpServer::~HttpServer() { Stop(); }

int HttpServer::Bind() {
  const HttpServerOptions& o = context_->options;
  if (o.port == 0) {
    const int port = server_->bind_to_any_port(o.bind);
    if (port <= 0) throw EnvironmentError(fmt::format("cannot bind to {}", o.bind));
    return port;
  }
  if (!server_->bind_to_port(o.bind, o.port)) {
    throw EnvironmentError(fmt::format("cannot bind to {}:{} (in use, or not a local address?)", o.bind, o.port));
  }
  return o.port;
}

void HttpServer::Run() {
  Context* ctx = context_.get();
  {
    std::lock_guard lock(ctx->sweep_mutex);
    ctx->sweep_stop = false;
  }
  std::thread sweeper([ctx] {
    std::unique_lock lock(ctx->sweep_mutex);
    while (!ctx->sweep_wake.wait_for(lock, ctx->options.upload_sweep_interval, [ctx] { return ctx->sweep_stop; })) {
      lock.unlock();
      try {
        ctx->uploads.RemoveExpired();
      } catch (const std::exception& e) {
        GLAM_LOG_WARN("expired uploads not removed: {}", e.what());
      }
      lock.lock();
    }
  });
  server_->listen_after_bind();
  {
    std::lock_guard lock(ctx->sweep_mutex);
    ctx->sweep_stop = true;
  }
  ctx->sweep_wake.notify_all();
  sweeper.join();
}

void HttpServer::Stop() {
  if (server_) server_->stop();
}

}  // namespace glam::server
