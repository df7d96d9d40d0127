// A file's bytes fed through a pipe by a thread, for tests of live-stream inputs
// (engine/video/stream_source.h) without a network: the source opens PipeFeeder::url().
#pragma once

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace glam::testing {

// A file's bytes written into a pipe by a thread, as a sender would; the source reads
// "pipe:<fd>". `bytes` limits what is written; `hold_open` keeps the pipe open afterwards (a
// sender gone silent) until Release() or destruction.
class PipeFeeder {
 public:
  explicit PipeFeeder(const std::filesystem::path& file, std::size_t bytes = SIZE_MAX, bool hold_open = false)
      : hold_open_(hold_open) {
    std::ifstream in(file, std::ios::binary);
    data_.assign(std::istreambuf_iterator<char>(in), {});
    if (bytes < data_.size()) data_.resize(bytes);
    int fds[2];
    EXPECT_EQ(pipe(fds), 0);
    read_fd_ = fds[0];
    write_fd_ = fds[1];
    // Non-blocking writes polled with a stop flag: the writer can always be stopped, even while
    // a reader holds the read end open without reading.
    fcntl(write_fd_, F_SETFL, fcntl(write_fd_, F_GETFL) | O_NONBLOCK);
    source_fd_ = dup(read_fd_);
    writer_ = std::thread([this] { Write(); });
  }
  ~PipeFeeder() {
    stop_.store(true);
    writer_.join();
    close(read_fd_);
    close(source_fd_);  // FFmpeg's pipe protocol never closes the descriptor it reads
  }
  // What the source opens; valid until the feeder is destroyed (destroy the source first).
  std::string url() const { return "pipe:" + std::to_string(source_fd_); }
  int source_fd() const { return source_fd_; }  // e.g. to become a child process' stdin
  void Release() { hold_open_.store(false); }

 private:
  void Write() {
    std::size_t at = 0;
    while (!stop_.load() && at < data_.size()) {
      const ssize_t n = write(write_fd_, data_.data() + at, data_.size() - at);
      if (n > 0) {
        at += static_cast<std::size_t>(n);
      } else if (n < 0 && errno == EAGAIN) {
        pollfd p{write_fd_, POLLOUT, 0};
        poll(&p, 1, 50);
      } else {
        break;  // EPIPE: every reader is gone
      }
    }
    while (!stop_.load() && hold_open_.load()) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    close(write_fd_);
  }

  std::vector<char> data_;
  int read_fd_ = -1, write_fd_ = -1, source_fd_ = -1;
  std::atomic<bool> stop_{false};
  std::atomic<bool> hold_open_;
  std::thread writer_;
};

}  // namespace glam::testing
