// Runs `glam serve` as a child process for tests that need a real process boundary (kill -9,
// SIGTERM). The server prints {"listening": ..., "port": N} on stdout once it accepts
// connections; Start() waits for that line.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace glam::testing {

class ServerProcess {
 public:
  ServerProcess() = default;
  ~ServerProcess();  // SIGKILLs a still running child
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  // Starts `glam_bin serve --data data_dir --port 0 <extra>`; returns false (with a message in
  // error()) if it exits or does not report its port within 30 s.
  bool Start(const std::string& glam_bin, const std::filesystem::path& data_dir,
             const std::vector<std::string>& extra = {});
  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  const std::string& error() const { return error_; }

  void Signal(int signal) const;
  // Waits up to `timeout_s` for the child to exit; returns its exit code, 128 + signal if it
  // was killed by a signal, or -1 on timeout.
  int Wait(int timeout_s);

 private:
  pid_t pid_ = -1;
  int stdout_fd_ = -1;
  int port_ = 0;
  std::string error_;
};

}  // namespace glam::testing
