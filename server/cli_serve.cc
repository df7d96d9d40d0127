// `glam serve --data DIR --port 8080 ...`: the mapping server. Prints one JSON line to stdout
// once it listens ({"listening": URL, "port": N}; with --port 0 that is how a caller learns
// the port) and runs until SIGINT / SIGTERM. Shutdown: stop accepting, end event streams,
// cancel running jobs without marking them canceled (they stay `running` in the store and are
// resumed on the next start), exit 0.
#include <pthread.h>
#include <signal.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <ctime>
#include <iostream>
#include <memory>
#include <string>
#include <thread>

#include <fmt/format.h>

#include "api/job_service.h"
#include "engine/core/error.h"
#include "engine/core/logging.h"
#include "server/commands.h"
#include "server/http_server.h"

namespace glam::cli {
namespace {

struct ServeArgs {
  std::string data_dir;
  std::string web_root;
  int concurrent_jobs = 1;
  int max_queued_jobs = 100;
  std::int64_t max_upload_mb = 8192;
  double upload_expiry_hours = 24;
  bool allow_streams = false;
  server::HttpServerOptions http;
};

// The viewer's directory when --web-root is not given: env GLAM_WEB_ROOT, then the build
// tree's web/dist (compiled in, so a developer's `glam serve` shows the viewer they just
// built), then the install layout <prefix>/share/glam/web next to <prefix>/bin/glam. Empty:
// the server falls back to its built-in job list page.
std::string DefaultWebRoot() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("GLAM_WEB_ROOT")) return env;
  auto has_index = [](const fs::path& dir) {
    std::error_code ec;
    return fs::is_regular_file(dir / "index.html", ec);
  };
#ifdef GLAM_DEFAULT_WEB_ROOT
  if (has_index(GLAM_DEFAULT_WEB_ROOT)) return GLAM_DEFAULT_WEB_ROOT;
#endif
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / "share" / "glam" / "web";
    if (has_index(installed)) return installed.string();
  }
  GLAM_LOG_WARN("no web viewer found (--web-root, GLAM_WEB_ROOT, the build's web/dist or "
                "<prefix>/share/glam/web); serving the built-in job list at /. "
                "Build the viewer with: bash scripts/setup-node.sh");
  return "";
}

void RunServe(ServeArgs& args) {
  if (args.http.token.empty()) {
    if (const char* env = std::getenv("GLAM_API_TOKEN")) args.http.token = env;
  }
  if (args.concurrent_jobs < 1 || args.concurrent_jobs > 64) {
    throw InputError(fmt::format("--concurrent-jobs must be in 1..64, got {}", args.concurrent_jobs));
  }
  if (args.max_queued_jobs < 1) throw InputError("--max-queued-jobs must be at least 1");
  if (args.max_upload_mb < 1 || args.max_upload_mb > (1LL << 24)) {
    throw InputError(fmt::format("--max-upload-mb must be in 1..{}, got {}", 1LL << 24, args.max_upload_mb));
  }
  args.http.max_upload_bytes = args.max_upload_mb << 20;
  if (!(args.upload_expiry_hours >= 1.0 / 60 && args.upload_expiry_hours <= 24 * 365)) {
    throw InputError(fmt::format("--upload-expiry-hours must be in 1/60..8760, got {}", args.upload_expiry_hours));
  }
  args.http.upload_expiry = std::chrono::seconds(static_cast<std::int64_t>(args.upload_expiry_hours * 3600));
  args.http.web_root = args.web_root.empty() ? DefaultWebRoot() : args.web_root;
  args.http.Check();

  // Signals are handled by one thread with sigwait; block them before any thread exists so
  // that no worker receives them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  api::JobServiceOptions service_options;
  service_options.data_dir = args.data_dir;
  service_options.concurrent_jobs = args.concurrent_jobs;
  service_options.max_queued_jobs = args.max_queued_jobs;
  service_options.allow_streams = args.allow_streams;
  api::JobService service(service_options);
  server::HttpServer http(service, args.http);
  const int port = http.Bind();

  std::atomic<bool> stopped{false};
  std::thread signal_thread([&] {
    const timespec poll{0, 200 * 1000 * 1000};
    while (!stopped) {
      const int sig = sigtimedwait(&signals, nullptr, &poll);
      if (sig == SIGINT || sig == SIGTERM) {
        GLAM_LOG_INFO("received {}; shutting down", sig == SIGINT ? "SIGINT" : "SIGTERM");
        http.Stop();
        service.Shutdown();
        return;
      }
    }
  });

  const std::string host = args.http.bind.find(':') != std::string::npos ? "[" + args.http.bind + "]" : args.http.bind;
  GLAM_LOG_INFO("glam serve: listening on http://{}:{} (data {}, {} HTTP threads{})", host, port,
                args.data_dir, args.http.http_threads, args.http.token.empty() ? ", no API token" : "");
  std::cout << fmt::format("{{\"listening\": \"http://{}:{}\", \"port\": {}}}", host, port, port) << std::endl;
  http.Run();
  stopped = true;
  signal_thread.join();
  service.Shutdown();
  GLAM_LOG_INFO("glam serve: stopped");
}

}  // namespace

void RegisterServeCommand(CLI::App& app) {
  auto args = std::make_shared<ServeArgs>();
  CLI::App* cmd = app.add_subcommand("serve", "Run the mapping server (REST API, job queue, viewer)");
  cmd->add_option("--data", args->data_dir, "Data directory (job store, uploads, results)")->required();
  cmd->add_option("--port", args->http.port, "TCP port (0 = any free port)")->capture_default_str();
  cmd->add_option("--bind", args->http.bind, "Address to listen on")->capture_default_str();
  cmd->add_option("--token", args->http.token,
                  "API token required on every /api/v1 request except health and openapi.yaml "
                  "(env GLAM_API_TOKEN)");
  cmd->add_option("--max-upload-mb", args->max_upload_mb, "Largest accepted upload (MiB)")->capture_default_str();
  cmd->add_option("--max-concurrent-uploads", args->http.max_concurrent_uploads,
                  "Uploads received at the same time (503 beyond)")
      ->capture_default_str();
  cmd->add_option("--max-open-uploads", args->http.max_open_uploads,
                  "Resumable uploads (POST /api/v1/uploads) open at the same time (503 beyond)")
      ->capture_default_str();
  cmd->add_option("--upload-expiry-hours", args->upload_expiry_hours,
                  "A resumable upload is deleted this long after its last byte arrived")
      ->capture_default_str();
  cmd->add_option("--concurrent-jobs", args->concurrent_jobs, "Mapping jobs run at the same time")
      ->capture_default_str();
  cmd->add_option("--max-queued-jobs", args->max_queued_jobs, "Queued jobs accepted (503 beyond)")
      ->capture_default_str();
  cmd->add_flag("--allow-streams", args->allow_streams,
                "Accept live-stream jobs (POST /jobs with a JSON body {\"stream_url\": \"rtsp://...\"}): the "
                "server then connects to the URLs clients send (rtsp, rtmp, srt, udp, rtp, tcp, http); off "
                "by default");
  cmd->add_option("--http-threads", args->http.http_threads, "HTTP worker threads")->capture_default_str();
  cmd->add_option("--max-sse-clients", args->http.max_sse_clients,
                  "Open event streams (each holds an HTTP thread; 503 beyond)")
      ->capture_default_str();
  cmd->add_option("--cors-origin", args->http.cors_origin,
                  "Allowed browser origin for cross-origin requests (default: none)");
  cmd->add_option("--web-root", args->web_root,
                  "Directory of the web viewer (default: env GLAM_WEB_ROOT, the build's web/dist, "
                  "<prefix>/share/glam/web, else a built-in job list page)");
  cmd->callback([args] { RunServe(*args); });
}

}  // namespace glam::cli
