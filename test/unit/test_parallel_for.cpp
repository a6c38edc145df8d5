// parallelFor (util/parallel_for.h): every index exactly once, on the threads asked for, errors
// rethrown, and the niceness of the calling thread kept by the new ones.
#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include "sag_hand_tracker/util/parallel_for.h"
#include "sag_hand_tracker/util/thread_priority.h"

using namespace sag_hand_tracker;

TEST(ParallelFor, CallsEveryIndexOnceOnTheThreadsAskedFor) {
  for (int threads : {0, 1, 2, 3, 8}) {
    std::vector<std::atomic<int>> calls(100);
    std::mutex mutex;
    std::set<std::thread::id> ids;
    parallelFor(100, threads, [&](int i) {
      ++calls[i];
      std::lock_guard<std::mutex> lock(mutex);
      ids.insert(std::this_thread::get_id());
      // Slow enough that every thread takes some indices.
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    });
    for (int i = 0; i < 100; ++i)
      EXPECT_EQ(calls[i], 1) << "index " << i << ", threads " << threads;
    EXPECT_LE(static_cast<int>(ids.size()), std::max(threads, 1));
    EXPECT_TRUE(ids.count(std::this_thread::get_id()));  // the caller works too
    if (threads > 1) EXPECT_GE(ids.size(), 2u) << threads << " threads";
  }
  int calls = 0;
  parallelFor(0, 4, [&](int) { ++calls; });
  EXPECT_EQ(calls, 0);
}

TEST(ParallelFor, RethrowsTheFirstErrorAfterAllThreadsEnded) {
  std::atomic<int> running{0};
  EXPECT_THROW(parallelFor(50, 3,
                           [&](int i) {
                             ++running;
                             std::this_thread::sleep_for(std::chrono::microseconds(100));
                             --running;
                             if (i == 7) throw std::runtime_error("candidate 7");
                           }),
               std::runtime_error);
  EXPECT_EQ(running, 0);  // no call still running once it returned
}

TEST(ParallelFor, NewThreadsKeepTheCallersNiceness) {
#ifndef __linux__
  GTEST_SKIP() << "per-thread nice values are Linux's";
#endif
  std::vector<int> niceness(20, -100);
  int caller = 0;
  std::thread lowered([&] {
    ASSERT_TRUE(lowerCurrentThreadPriority(3));
    caller = currentThreadNiceness();
    parallelFor(20, 2, [&](int i) {
      niceness[i] = currentThreadNiceness();
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    });
  });
  lowered.join();
  for (int value : niceness) EXPECT_EQ(value, caller);
}
