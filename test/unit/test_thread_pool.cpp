// ThreadPool (util/thread_pool.h): parallelFor's contract on threads that stay, call after call.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "sag_hand_tracker/util/thread_pool.h"

using namespace sag_hand_tracker;

// Every index exactly once in every call, on at most the pool's threads, the caller among them,
// and on the same helper threads from call to call.
TEST(ThreadPool, CallsEveryIndexOnceOnItsKeptThreads) {
  for (int threads : {0, 1, 2, 3}) {
    ThreadPool pool(threads);
    EXPECT_EQ(pool.threads(), std::max(threads, 1));
    std::set<std::thread::id> all_ids;
    for (int call = 0; call < 20; ++call) {
      const int count = call % 7;  // 0 to 6 indices: fewer than, as many as, more than threads
      std::vector<std::atomic<int>> calls(count);
      std::mutex mutex;
      pool.run(count, [&](int i) {
        ++calls[i];
        std::lock_guard<std::mutex> lock(mutex);
        all_ids.insert(std::this_thread::get_id());
        std::this_thread::sleep_for(std::chrono::microseconds(300));
      });
      for (int i = 0; i < count; ++i) {
        EXPECT_EQ(calls[i], 1) << "index " << i << ", call " << call << ", threads " << threads;
      }
    }
    EXPECT_TRUE(all_ids.count(std::this_thread::get_id()));
    // Threads that stay: over 20 calls no more distinct threads than the pool has.
    EXPECT_LE(static_cast<int>(all_ids.size()), std::max(threads, 1));
    if (threads > 1) EXPECT_GE(all_ids.size(), 2u);
  }
}

// The first error comes back once no call is running any more, the remaining indices are
// skipped, and the pool works on afterwards.
TEST(ThreadPool, RethrowsTheFirstErrorAndWorksOn) {
  ThreadPool pool(3);
  std::atomic<int> running{0};
  EXPECT_THROW(pool.run(50,
                        [&](int i) {
                          ++running;
                          std::this_thread::sleep_for(std::chrono::microseconds(100));
                          --running;
                          if (i == 7) throw std::runtime_error("view 7");
                        }),
               std::runtime_error);
  EXPECT_EQ(running, 0);
  std::atomic<int> sum{0};
  pool.run(10, [&](int i) { sum += i; });
  EXPECT_EQ(sum, 45);
}

// Calls from two threads at once take turns: each gets all its indices, none of the other's.
TEST(ThreadPool, CallsFromSeveralThreadsTakeTurns) {
  ThreadPool pool(2);
  std::vector<std::atomic<int>> a(40), b(40);
  std::thread other([&] {
    for (int r = 0; r < 10; ++r) pool.run(40, [&](int i) { ++b[i]; });
  });
  for (int r = 0; r < 10; ++r) pool.run(40, [&](int i) { ++a[i]; });
  other.join();
  for (int i = 0; i < 40; ++i) {
    EXPECT_EQ(a[i], 10);
    EXPECT_EQ(b[i], 10);
  }
}
