#include "engine/pipeline/alignment_thread.h"

#include <chrono>

#include "engine/core/error.h"
#include "engine/core/thread_name.h"

namespace glam {

AlignmentThread::AlignmentThread(SubmapAligner& aligner, std::size_t queue_capacity)
    : aligner_(aligner), queue_(queue_capacity), thread_([this] { Run(); }) {}

AlignmentThread::~AlignmentThread() {
  if (thread_.joinable()) Abort();
}

void AlignmentThread::Run() {
  NameCurrentThread("glam-align");
  try {
    while (std::optional<std::shared_ptr<const Submap>> submap = queue_.Pop()) {
      if (aborting_.load()) break;
      const auto start = std::chrono::steady_clock::now();
      aligner_.Add(**submap);
      landmarks_[(*submap)->id] = (*submap)->landmarks.size();
      const std::shared_ptr<const MapSnapshot> snapshot = aligner_.snapshot();
      std::int64_t connected = 0, points = 0;
      for (const SubmapPlacement& p : snapshot->submaps) {
        if (p.disconnected) continue;
        ++connected;
        points += static_cast<std::int64_t>(landmarks_[p.id]);
      }
      submaps_aligned_.store(connected);
      points_.store(points);
      revision_.store(snapshot->revision);
      busy_seconds_ +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
  } catch (...) {
    error_ = std::current_exception();
    failed_.store(true);
    queue_.Close();  // producers stop waiting for room
  }
}

void AlignmentThread::Push(std::shared_ptr<const Submap> submap) {
  if (!queue_.Push(std::move(submap))) {
    RethrowIfFailed();
    GLAM_CHECK(false, "Push after Finish or Abort");
  }
}

void AlignmentThread::RethrowIfFailed() const {
  if (failed_.load()) std::rethrow_exception(error_);
}

void AlignmentThread::Finish() {
  queue_.Close();
  if (thread_.joinable()) thread_.join();
  RethrowIfFailed();
}

void AlignmentThread::Abort() {
  aborting_.store(true);
  queue_.Close();
  if (thread_.joinable()) thread_.join();
}

}  // namespace glam
