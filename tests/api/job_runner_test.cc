#include "api/job_runner.h"

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace glam::api {
namespace {

using namespace std::chrono_literals;

// Work that runs until cancelled, recording start order.
struct Recorder {
  std::mutex mutex;
  std::vector<std::string> started;
  std::vector<std::string> cancelled;
  std::atomic<int> active{0};
  std::atomic<int> max_active{0};

  void Run(const std::string& id, const CancellationToken& cancel, std::chrono::milliseconds length) {
    {
      std::lock_guard lock(mutex);
      started.push_back(id);
    }
    const int now = ++active;
    int prev = max_active.load();
    while (now > prev && !max_active.compare_exchange_weak(prev, now)) {
    }
    const auto end = std::chrono::steady_clock::now() + length;
    while (std::chrono::steady_clock::now() < end) {
      if (cancel.IsCancelled()) {
        std::lock_guard lock(mutex);
        cancelled.push_back(id);
        break;
      }
      std::this_thread::sleep_for(2ms);
    }
    --active;
  }
};

TEST(JobRunner, RunsInFifoOrderWithBoundedConcurrency) {
  Recorder rec;
  JobRunner runner(2, [&](const std::string& id, const CancellationToken& c) { rec.Run(id, c, 30ms); });
  for (const char* id : {"a", "b", "c", "d", "e"}) runner.Enqueue(id);
  for (const char* id : {"a", "b", "c", "d", "e"}) EXPECT_TRUE(runner.WaitUntilIdle(id, 5s));
  EXPECT_EQ(rec.started.size(), 5u);
  EXPECT_EQ(rec.started.back(), "e");
  EXPECT_LE(rec.max_active.load(), 2);
  EXPECT_EQ(rec.max_active.load(), 2);
}

TEST(JobRunner, RemoveQueuedAndCancelRunning) {
  Recorder rec;
  JobRunner runner(1, [&](const std::string& id, const CancellationToken& c) { rec.Run(id, c, 10s); });
  runner.Enqueue("first");
  runner.Enqueue("second");
  runner.Enqueue("second");  // already queued: ignored
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (!runner.IsRunning("first") && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(1ms);
  ASSERT_TRUE(runner.IsRunning("first"));
  EXPECT_EQ(runner.queued(), 1u);
  EXPECT_TRUE(runner.RemoveQueued("second"));
  EXPECT_FALSE(runner.RemoveQueued("second"));
  EXPECT_FALSE(runner.CancelRunning("second"));
  EXPECT_TRUE(runner.CancelRunning("first"));
  EXPECT_TRUE(runner.WaitUntilIdle("first", 5s));
  ASSERT_EQ(rec.cancelled.size(), 1u);
  EXPECT_EQ(rec.cancelled[0], "first");
  EXPECT_EQ(rec.started.size(), 1u);  // "second" never started
}

// A restart that arrives while the job's previous run is still returning (the job already
// looks completed to clients) must not be lost: the job runs again once that run returns.
TEST(JobRunner, EnqueuedWhileRunningRunsAgainAfterwards) {
  Recorder rec;
  JobRunner runner(1, [&](const std::string& id, const CancellationToken& c) { rec.Run(id, c, 100ms); });
  runner.Enqueue("a");
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (!runner.IsRunning("a") && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(1ms);
  ASSERT_TRUE(runner.IsRunning("a"));
  runner.Enqueue("a");
  runner.Enqueue("a");  // one pending run, not two
  EXPECT_TRUE(runner.WaitUntilIdle("a", 5s));
  EXPECT_EQ(rec.started, (std::vector<std::string>{"a", "a"}));
  // A pending run can be withdrawn like a queued one.
  runner.Enqueue("b");
  while (!runner.IsRunning("b") && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(1ms);
  ASSERT_TRUE(runner.IsRunning("b"));
  runner.Enqueue("b");
  EXPECT_TRUE(runner.RemoveQueued("b"));
  EXPECT_TRUE(runner.WaitUntilIdle("b", 5s));
  EXPECT_EQ(rec.started.size(), 3u);
}

TEST(JobRunner, ShutdownCancelsRunningAndLeavesQueued) {
  Recorder rec;
  std::atomic<bool> saw_shutdown{false};
  std::unique_ptr<JobRunner> runner;
  runner = std::make_unique<JobRunner>(1, [&](const std::string& id, const CancellationToken& c) {
    rec.Run(id, c, 10s);
    if (runner->shutting_down()) saw_shutdown = true;
  });
  runner->Enqueue("x");
  runner->Enqueue("y");
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (!runner->IsRunning("x") && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(1ms);
  const auto start = std::chrono::steady_clock::now();
  runner->Shutdown();
  EXPECT_LT(std::chrono::steady_clock::now() - start, 5s);
  EXPECT_TRUE(saw_shutdown);
  EXPECT_EQ(rec.started.size(), 1u);
  runner->Enqueue("z");  // ignored after shutdown
  EXPECT_EQ(runner->running(), 0u);
}

}  // namespace
}  // namespace glam::api
