#include "server/cli_progress.h"

#include <algorithm>
#include <iostream>

#include <fmt/format.h>

#include "engine/core/logging.h"

namespace glam::cli {
namespace {

constexpr int kBarWidth = 30;

std::string Bar(double fraction) {
  const int filled = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * kBarWidth);
  std::string bar(kBarWidth + 2, '.');
  bar.front() = '[';
  bar.back() = ']';
  std::fill_n(bar.begin() + 1, filled, '#');
  return bar;
}

}  // namespace

std::string FormatDuration(double seconds) {
  if (seconds < 0) return "--:--";
  const long s = static_cast<long>(seconds + 0.5);
  return s >= 3600 ? fmt::format("{}:{:02}:{:02}", s / 3600, (s / 60) % 60, s % 60)
                   : fmt::format("{:02}:{:02}", s / 60, s % 60);
}

void DrawProgress(const MappingProgress& p, bool tty) {
  const std::string counts = p.frames_total > 0 ? fmt::format("{}/{}", p.frames_done, p.frames_total)
                                                 : fmt::format("{}", p.frames_done);
  const std::string tail = fmt::format("{} frames  {:.1f} fps  ETA {}  submaps {}  keyframes {}",
                                       counts, p.fps, FormatDuration(p.eta_s), p.submaps_completed,
                                       p.keyframes);
  if (!tty) {
    GLAM_LOG_INFO("{}: {}", p.stage, tail);
    return;
  }
  const double fraction =
      p.frames_total > 0 ? std::min(1.0, static_cast<double>(p.frames_done) / p.frames_total) : 0;
  std::cerr << fmt::format("\r\033[K{:<8} {} {:3.0f}%  {}", p.stage, Bar(fraction), 100 * fraction, tail)
            << std::flush;
}

void DrawUploadProgress(const std::string& label, std::int64_t sent, std::int64_t total, double bytes_per_s,
                        const std::string& retry, bool tty) {
  const double fraction = total > 0 ? static_cast<double>(sent) / static_cast<double>(total) : 0;
  const double eta = bytes_per_s > 0 ? static_cast<double>(total - sent) / bytes_per_s : -1;
  const std::string tail = fmt::format("{:.1f}/{:.1f} MB  {:.1f} MB/s  ETA {}", sent / 1e6, total / 1e6,
                                       bytes_per_s / 1e6, FormatDuration(eta));
  if (!tty) {
    if (retry.empty()) {
      GLAM_LOG_INFO("uploading {}: {}", label, tail);
    }
    return;  // retries are logged as warnings by the client
  }
  std::cerr << fmt::format("\r\033[Kupload   {} {:3.0f}%  {}", Bar(fraction), 100 * fraction, tail);
  if (!retry.empty()) std::cerr << fmt::format("  (retrying: {})", retry);
  std::cerr << std::flush;
}

}  // namespace glam::cli
