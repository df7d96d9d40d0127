// Request counters and latency histograms per route for /api/v1/metrics (Prometheus text
// format 0.0.4). Routes are the OpenAPI path templates ("/api/v1/jobs/{id}"), never raw paths,
// so the label set stays bounded whatever clients send.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <tuple>

namespace glam::server {

class HttpMetrics {
 public:
  static constexpr std::array<double, 11> kBuckets = {0.001, 0.0025, 0.005, 0.01, 0.025, 0.05,
                                                      0.1,   0.25,   0.5,   1.0,  5.0};

  void Observe(const std::string& route, const std::string& method, int status, double seconds);
  // Appends the http_* families to `out`.
  void Render(std::string* out) const;

 private:
  struct Histogram {
    std::array<std::uint64_t, kBuckets.size()> buckets{};
    std::uint64_t count = 0;
    double sum = 0;
  };
  mutable std::mutex mutex_;
  std::map<std::tuple<std::string, std::string, int>, std::uint64_t> requests_;
  std::map<std::string, Histogram> latency_;  // by route
};

}  // namespace glam::server
