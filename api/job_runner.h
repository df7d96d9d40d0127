// The job queue: N worker threads (default 1: on 2 cores one mapping job already keeps both
// busy) take job ids in FIFO order and run them through a callback that owns the actual work.
// The runner knows nothing about the store or the engine, which keeps its threading (queue,
// per-job cancellation, shutdown that cancels and joins) testable on its own.
#pragma once

#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "engine/core/cancellation.h"

namespace glam::api {

class JobRunner {
 public:
  // Runs one job; must not throw (the runner logs and swallows anything that escapes).
  using Work = std::function<void(const std::string& job_id, const CancellationToken& cancel)>;

  JobRunner(int workers, Work work);
  ~JobRunner();  // Shutdown()
  JobRunner(const JobRunner&) = delete;
  JobRunner& operator=(const JobRunner&) = delete;

  // Ignored after Shutdown() or if the id is already queued. A job still running (its work
  // has not returned yet, although the job may already look finished to clients: a restart
  // right after completion) is queued again as soon as its run returns, so the request is not
  // lost.
  void Enqueue(const std::string& job_id);
  // Removes a job that has not started yet (or a pending run after the current one); false if
  // it is not in the queue.
  bool RemoveQueued(const std::string& job_id);
  // Cancels the token of a running job; false if it is not running.
  bool CancelRunning(const std::string& job_id);
  bool IsRunning(const std::string& job_id) const;
  // Waits until the job is neither queued nor running; false on timeout.
  bool WaitUntilIdle(const std::string& job_id, std::chrono::milliseconds timeout) const;

  std::size_t queued() const;
  std::size_t running() const;

  // Stops taking work, cancels every running job (their Work sees the token cancelled while
  // shutting_down() is true) and joins the workers. Queued jobs stay queued (not started).
  void Shutdown();
  bool shutting_down() const;

 private:
  void WorkerLoop();

  Work work_;
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::deque<std::string> queue_;
  std::map<std::string, CancellationToken> running_;
  std::set<std::string> rerun_;  // enqueued while running: queued again when that run returns
  bool stopping_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace glam::api
