#include "server/http_metrics.h"

#include <fmt/format.h>

namespace glam::server {

void HttpMetrics::Observe(const std::string& route, const std::string& method, int status,
                          double seconds) {
  std::lock_guard lock(mutex_);
  ++requests_[{route, method, status}];
  Histogram& h = latency_[route];
  for (std::size_t i = 0; i < kBuckets.size(); ++i) {
    if (seconds <= kBuckets[i]) ++h.buckets[i];
  }
  ++h.count;
  h.sum += seconds;
}

void HttpMetrics::Render(std::string* out) const {
  std::lock_guard lock(mutex_);
  *out += "# HELP glam_http_requests_total HTTP requests by route, method and status.\n";
  *out += "# TYPE glam_http_requests_total counter\n";
  for (const auto& [key, count] : requests_) {
    const auto& [route, method, status] = key;
    *out += fmt::format("glam_http_requests_total{{route=\"{}\",method=\"{}\",code=\"{}\"}} {}\n",
                        route, method, status, count);
  }
  *out += "# HELP glam_http_request_duration_seconds Handler time by route.\n";
  *out += "# TYPE glam_http_request_duration_seconds histogram\n";
  for (const auto& [route, h] : latency_) {
    for (std::size_t i = 0; i < kBuckets.size(); ++i) {
      *out += fmt::format("glam_http_request_duration_seconds_bucket{{route=\"{}\",le=\"{}\"}} {}\n",
                          route, kBuckets[i], h.buckets[i]);
    }
    *out += fmt::format("glam_http_request_duration_seconds_bucket{{route=\"{}\",le=\"+Inf\"}} {}\n",
                        route, h.count);
    *out += fmt::format("glam_http_request_duration_seconds_sum{{route=\"{}\"}} {}\n", route, h.sum);
    *out += fmt::format("glam_http_request_duration_seconds_count{{route=\"{}\"}} {}\n", route, h.count);
  }
}

}  // namespace glam::server
