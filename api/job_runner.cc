#include "api/job_runner.h"

#include <algorithm>
#include <exception>

#include "engine/core/logging.h"
#include "engine/core/thread_name.h"

namespace glam::api {

JobRunner::JobRunner(int workers, Work work) : work_(std::move(work)) {
  workers = std::max(1, workers);
  for (int i = 0; i < workers; ++i) {
    workers_.emplace_back([this] {
      NameCurrentThread("glam-job");
      WorkerLoop();
    });
  }
}

JobRunner::~JobRunner() { Shutdown(); }

void JobRunner::Enqueue(const std::string& job_id) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    if (std::find(queue_.begin(), queue_.end(), job_id) != queue_.end()) return;
    if (running_.count(job_id) != 0) {
      rerun_.insert(job_id);
      return;
    }
    queue_.push_back(job_id);
  }
  changed_.notify_all();
}

bool JobRunner::RemoveQueued(const std::string& job_id) {
  bool removed = false;
  {
    std::lock_guard lock(mutex_);
    const auto it = std::find(queue_.begin(), queue_.end(), job_id);
    if (it != queue_.end()) {
      queue_.erase(it);
      removed = true;
    }
    if (rerun_.erase(job_id) != 0) removed = true;
  }
  if (removed) changed_.notify_all();
  return removed;
}

bool JobRunner::CancelRunning(const std::string& job_id) {
  std::lock_guard lock(mutex_);
  const auto it = running_.find(job_id);
  if (it == running_.end()) return false;
  it->second.Cancel();
  return true;
}

bool JobRunner::IsRunning(const std::string& job_id) const {
  std::lock_guard lock(mutex_);
  return running_.count(job_id) != 0;
}

bool JobRunner::WaitUntilIdle(const std::string& job_id, std::chrono::milliseconds timeout) const {
  std::unique_lock lock(mutex_);
  return changed_.wait_for(lock, timeout, [&] {
    return running_.count(job_id) == 0 && rerun_.count(job_id) == 0 &&
           std::find(queue_.begin(), queue_.end(), job_id) == queue_.end();
  });
}

std::size_t JobRunner::queued() const {
  std::lock_guard lock(mutex_);
  return queue_.size();
}

std::size_t JobRunner::running() const {
  std::lock_guard lock(mutex_);
  return running_.size();
}

bool JobRunner::shutting_down() const {
  std::lock_guard lock(mutex_);
  return stopping_;
}

void JobRunner::Shutdown() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && workers_.empty()) return;
    stopping_ = true;
    for (auto& [id, token] : running_) token.Cancel();
  }
  changed_.notify_all();
  for (std::thread& worker : workers_) {
    if (worker.joinable()) worker.join();
  }
  workers_.clear();
}

void JobRunner::WorkerLoop() {
  for (;;) {
    std::string job_id;
    CancellationToken token;
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (stopping_) return;
      job_id = queue_.front();
      queue_.pop_front();
      running_.emplace(job_id, token);
    }
    try {
      work_(job_id, token);
    } catch (const std::exception& e) {
      GLAM_LOG_ERROR("job {}: unexpected error escaped the runner: {}", job_id, e.what());
    } catch (...) {
      GLAM_LOG_ERROR("job {}: unknown error escaped the runner", job_id);
    }
    {
      std::lock_guard lock(mutex_);
      running_.erase(job_id);
      if (rerun_.erase(job_id) != 0 && !stopping_) queue_.push_back(job_id);
    }
    changed_.notify_all();
  }
}

}  // namespace glam::api
