// The worker's lower priority (TrackerParams::worker_niceness): only the calling thread changes.
#include <gtest/gtest.h>

#include <thread>

#include "sag_hand_tracker/util/thread_priority.h"

using namespace sag_hand_tracker;

TEST(ThreadPriority, LowersOnlyTheCallingThread) {
#ifndef __linux__
  GTEST_SKIP() << "per-thread nice values are Linux's";
#endif
  const int before = currentThreadNiceness();
  int worker_before = 0, worker_after = 0;
  bool lowered = false;
  std::thread worker([&] {
    worker_before = currentThreadNiceness();
    lowered = lowerCurrentThreadPriority(5);
    worker_after = currentThreadNiceness();
  });
  worker.join();
  EXPECT_TRUE(lowered);
  EXPECT_EQ(worker_before, before);  // a new thread starts at its creator's value
  EXPECT_EQ(worker_after, std::min(before + 5, 19));
  EXPECT_EQ(currentThreadNiceness(), before);  // the process' other threads keep theirs
  EXPECT_TRUE(lowerCurrentThreadPriority(0));
  EXPECT_EQ(currentThreadNiceness(), before);
}
