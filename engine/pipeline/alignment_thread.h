// Thread 2 of a mapping run: owns the thread that feeds completed submaps to the
// SubmapAligner, so thread 1 (the submap builder) never waits for retrieval, verification or
// graph optimisation unless the bounded hand-off queue is full. Counters for progress are
// atomics, read by the run's thread; an error on thread 2 is kept and rethrown to the run's
// thread, and the destructor always joins.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <map>
#include <memory>
#include <thread>

#include "engine/alignment/submap_aligner.h"
#include "engine/core/bounded_queue.h"
#include "engine/map/submap.h"

namespace glam {

class AlignmentThread {
 public:
  AlignmentThread(SubmapAligner& aligner, std::size_t queue_capacity);
  ~AlignmentThread();  // Abort() if still running
  AlignmentThread(const AlignmentThread&) = delete;
  AlignmentThread& operator=(const AlignmentThread&) = delete;

  // Blocks while the queue is full. Rethrows thread 2's error if it has failed.
  void Push(std::shared_ptr<const Submap> submap);
  void RethrowIfFailed() const;
  // End of input: aligns what is queued, joins, rethrows thread 2's error if any.
  void Finish();
  // The run is failing anyway: drop queued submaps, join, swallow thread 2's error.
  void Abort();

  std::int64_t submaps_aligned() const { return submaps_aligned_.load(); }  // connected ones
  std::int64_t revision() const { return revision_.load(); }
  std::int64_t points() const { return points_.load(); }  // landmarks of connected submaps
  double busy_seconds() const { return busy_seconds_; }   // valid after Finish()

 private:
  void Run();

  SubmapAligner& aligner_;
  BoundedQueue<std::shared_ptr<const Submap>> queue_;
  std::atomic<bool> aborting_{false};
  std::atomic<bool> failed_{false};
  std::exception_ptr error_;  // written by thread 2 before failed_ is set
  std::atomic<std::int64_t> submaps_aligned_{0};
  std::atomic<std::int64_t> revision_{0};
  std::atomic<std::int64_t> points_{0};
  std::map<std::uint32_t, std::size_t> landmarks_;  // thread 2 only
  double busy_seconds_ = 0;
  std::thread thread_;
};

}  // namespace glam
