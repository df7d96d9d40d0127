#include "engine/core/bounded_queue.h"

#include <algorithm>
#include <atomic>
#include <memory>
#include <chrono>
#include <numeric>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace glam {
namespace {

TEST(BoundedQueue, FifoOrderSingleThread) {
  BoundedQueue<int> q(4);
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(q.Push(i));
  EXPECT_EQ(q.Size(), 4u);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(q.Pop(), i);
}

TEST(BoundedQueue, CloseDrainsThenEnds) {
  BoundedQueue<int> q(4);
  q.Push(1);
  q.Push(2);
  q.Close();
  EXPECT_FALSE(q.Push(3));
  EXPECT_EQ(q.Pop(), 1);
  EXPECT_EQ(q.Pop(), 2);
  EXPECT_EQ(q.Pop(), std::nullopt);
}

TEST(BoundedQueue, PopForTimesOutWhenEmpty) {
  BoundedQueue<int> q(1);
  EXPECT_EQ(q.PopFor(std::chrono::milliseconds(20)), std::nullopt);
  EXPECT_FALSE(q.IsClosed());
}

TEST(BoundedQueue, ProducerBlocksWhileFull) {
  BoundedQueue<int> q(2);
  q.Push(0);
  q.Push(1);
  std::atomic<bool> pushed{false};
  std::thread producer([&] {
    q.Push(2);
    pushed = true;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  EXPECT_FALSE(pushed.load());  // capacity bound holds
  EXPECT_EQ(q.Pop(), 0);
  producer.join();
  EXPECT_TRUE(pushed.load());
  EXPECT_EQ(q.Size(), 2u);
}

TEST(BoundedQueue, CloseWakesBlockedProducerAndConsumer) {
  BoundedQueue<int> full(1);
  full.Push(0);
  BoundedQueue<int> empty(1);
  std::atomic<int> results{0};
  std::thread producer([&] { results += full.Push(1) ? 100 : 1; });
  std::thread consumer([&] { results += empty.Pop().has_value() ? 100 : 1; });
  std::this_thread::sleep_for(std::chrono::milliseconds(30));
  full.Close();
  empty.Close();
  producer.join();
  consumer.join();
  EXPECT_EQ(results.load(), 2);  // both returned "closed", neither hung
}

TEST(BoundedQueue, ManyProducersManyConsumersDeliverEverythingOnce) {
  constexpr int kProducers = 4, kConsumers = 3, kPerProducer = 2000;
  BoundedQueue<int> q(8);
  std::vector<std::thread> producers, consumers;
  std::vector<std::vector<int>> received(kConsumers);
  for (int p = 0; p < kProducers; ++p) {
    producers.emplace_back([&, p] {
      for (int i = 0; i < kPerProducer; ++i) ASSERT_TRUE(q.Push(p * kPerProducer + i));
    });
  }
  for (int c = 0; c < kConsumers; ++c) {
    consumers.emplace_back([&, c] {
      while (auto v = q.Pop()) received[c].push_back(*v);
    });
  }
  for (auto& t : producers) t.join();
  q.Close();
  for (auto& t : consumers) t.join();
  std::vector<int> all;
  for (const auto& r : received) all.insert(all.end(), r.begin(), r.end());
  ASSERT_EQ(all.size(), static_cast<size_t>(kProducers * kPerProducer));
  std::sort(all.begin(), all.end());
  for (int i = 0; i < kProducers * kPerProducer; ++i) ASSERT_EQ(all[i], i);
  // Per producer, consumers see values in push order (FIFO per consumer).
  for (const auto& r : received) {
    std::vector<int> last(kProducers, -1);
    for (int v : r) {
      EXPECT_GT(v, last[v / kPerProducer]);
      last[v / kPerProducer] = v;
    }
  }
}

TEST(BoundedQueue, MoveOnlyPayload) {
  BoundedQueue<std::unique_ptr<int>> q(1);
  q.Push(std::make_unique<int>(7));
  auto v = q.Pop();
  ASSERT_TRUE(v.has_value());
  EXPECT_EQ(**v, 7);
}

}  // namespace
}  // namespace glam
