// Load generator for `glam serve` (not a test; bench/load/run.sh drives it): N parallel
// uploads of one video, then a fixed rate of status polls (GET /jobs/{id}, every tenth a
// GET /jobs list) spread over several keep-alive connections, plus a few SSE followers, for
// a given duration while the server maps. Prints latency percentiles and error counts as
// text and one JSON line.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>
#include <nlohmann/json.hpp>

namespace {

using Clock = std::chrono::steady_clock;

struct Samples {
  std::mutex mutex;
  std::vector<double> ms;
  int errors = 0;
  std::map<int, int> statuses;
  void Add(double value, int status, bool ok) {
    std::lock_guard lock(mutex);
    ms.push_back(value);
    ++statuses[status];
    if (!ok) ++errors;
  }
  nlohmann::json Summary() {
    std::lock_guard lock(mutex);
    std::sort(ms.begin(), ms.end());
    auto pct = [&](double p) {
      if (ms.empty()) return 0.0;
      return ms[std::min(ms.size() - 1, static_cast<std::size_t>(p * (ms.size() - 1) + 0.5))];
    };
    nlohmann::json codes = nlohmann::json::object();
    for (const auto& [code, n] : statuses) codes[std::to_string(code)] = n;
    return {{"count", ms.size()}, {"errors", errors}, {"p50_ms", pct(0.5)}, {"p95_ms", pct(0.95)},
            {"p99_ms", pct(0.99)}, {"max_ms", ms.empty() ? 0.0 : ms.back()}, {"status", codes}};
  }
};

std::string Arg(int argc, char** argv, const std::string& name, const std::string& fallback) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (argv[i] == name) return argv[i + 1];
  }
  return fallback;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string host = Arg(argc, argv, "--host", "127.0.0.1");
  const int port = std::stoi(Arg(argc, argv, "--port", "8080"));
  const std::string video_path = Arg(argc, argv, "--video", "");
  const int uploads = std::stoi(Arg(argc, argv, "--uploads", "10"));
  const double poll_rate = std::stod(Arg(argc, argv, "--poll-rate", "100"));
  const int poll_threads = std::stoi(Arg(argc, argv, "--poll-threads", "4"));
  const int sse_clients = std::stoi(Arg(argc, argv, "--sse-clients", "2"));
  const double duration_s = std::stod(Arg(argc, argv, "--duration", "60"));
  const std::string token = Arg(argc, argv, "--token", "");
  if (video_path.empty()) {
    std::cerr << "usage: glam_loadtest --port P --video FILE [--uploads 10] [--poll-rate 100] "
                 "[--poll-threads 4] [--sse-clients 2] [--duration 60] [--token T]\n";
    return 2;
  }
  std::ifstream in(video_path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string video = buffer.str();
  auto make_client = [&] {
    auto client = std::make_unique<httplib::Client>(host, port);
    client->set_keep_alive(true);
    client->set_tcp_nodelay(true);
    client->set_read_timeout(std::chrono::seconds(120));
    client->set_write_timeout(std::chrono::seconds(120));
    if (!token.empty()) client->set_bearer_token_auth(token);
    return client;
  };

  Samples upload_samples;
  Samples poll_samples;
  std::mutex ids_mutex;
  std::vector<std::string> ids;
  std::atomic<bool> stop{false};
  std::atomic<long> sse_events{0};
  const auto start = Clock::now();

  // Polls start at once (they measure status latency while uploads stream in and jobs map).
  std::vector<std::thread> threads;
  for (int t = 0; t < poll_threads; ++t) {
    threads.emplace_back([&, t] {
      auto client = make_client();
      const auto interval = std::chrono::duration<double>(poll_threads / poll_rate);
      auto next = Clock::now() + std::chrono::duration_cast<Clock::duration>(interval * t / poll_threads);
      long n = 0;
      while (!stop) {
        std::this_thread::sleep_until(next);
        next += std::chrono::duration_cast<Clock::duration>(interval);
        std::string path = "/api/v1/jobs?limit=20";
        {
          std::lock_guard lock(ids_mutex);
          if (!ids.empty() && n % 10 != 0) path = "/api/v1/jobs/" + ids[n % ids.size()];
        }
        ++n;
        const auto t0 = Clock::now();
        auto res = client->Get(path);
        const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        poll_samples.Add(ms, res ? res->status : -1, res && res->status == 200);
      }
    });
  }
  for (int u = 0; u < uploads; ++u) {
    threads.emplace_back([&, u] {
      auto client = make_client();
      httplib::MultipartFormDataItems items = {
          {"video", video, "load.mp4", "video/mp4"},
          {"options", "{\"name\": \"load " + std::to_string(u) + "\"}", "", "application/json"}};
      const auto t0 = Clock::now();
      auto res = client->Post("/api/v1/jobs", items);
      const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
      const bool ok = res && res->status == 201;
      upload_samples.Add(ms, res ? res->status : -1, ok);
      if (ok) {
        std::lock_guard lock(ids_mutex);
        ids.push_back(nlohmann::json::parse(res->body)["id"]);
      }
    });
  }
  for (int s = 0; s < sse_clients; ++s) {
    threads.emplace_back([&, s] {
      std::string id;
      while (!stop && id.empty()) {
        {
          std::lock_guard lock(ids_mutex);
          if (static_cast<int>(ids.size()) > s) id = ids[s];
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
      auto client = make_client();
      client->Get("/api/v1/jobs/" + id + "/events", [&](const char* data, std::size_t size) {
        for (std::size_t i = 0; i + 1 < size; ++i) {
          if (data[i] == '\n' && data[i + 1] == '\n') ++sse_events;
        }
        return !stop;
      });
    });
  }
  std::this_thread::sleep_for(std::chrono::duration<double>(duration_s));
  stop = true;
  for (std::thread& t : threads) t.join();
  const double elapsed = std::chrono::duration<double>(Clock::now() - start).count();

  nlohmann::json report = {{"duration_s", elapsed},
                           {"uploads", upload_samples.Summary()},
                           {"polls", poll_samples.Summary()},
                           {"sse_events", sse_events.load()}};
  report["polls"]["rate_per_s"] = report["polls"]["count"].get<double>() / elapsed;
  const auto& p = report["polls"];
  const auto& u = report["uploads"];
  std::printf("uploads: %d ok of %d, p50 %.1f ms, p99 %.1f ms, max %.1f ms\n",
              u["count"].get<int>() - u["errors"].get<int>(), u["count"].get<int>(),
              u["p50_ms"].get<double>(), u["p99_ms"].get<double>(), u["max_ms"].get<double>());
  std::printf("polls:   %d (%.1f/s), errors %d, p50 %.2f ms, p95 %.2f ms, p99 %.2f ms, max %.1f ms\n",
              p["count"].get<int>(), p["rate_per_s"].get<double>(), p["errors"].get<int>(),
              p["p50_ms"].get<double>(), p["p95_ms"].get<double>(), p["p99_ms"].get<double>(),
              p["max_ms"].get<double>());
  std::printf("sse events received: %ld\n", sse_events.load());
  std::printf("%s\n", report.dump().c_str());
  return (u["errors"].get<int>() == 0 && p["errors"].get<int>() == 0) ? 0 : 1;
}
