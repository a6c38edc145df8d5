// ProduceAhead (util/produce_ahead.h): results in order, at most `depth` ahead, the end and errors
// reported, the producer at a lower priority, and a clean stop while it waits.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include "sag_hand_tracker/util/produce_ahead.h"

namespace sag_hand_tracker {
namespace {

// Takes the next result, waiting for it at most 5 s.
template <typename T>
std::optional<T> takeWaiting(ProduceAhead<T>& ahead) {
  for (int i = 0; i < 5000; ++i) {
    if (std::optional<T> item = ahead.tryTake()) return item;
    if (ahead.finished()) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return std::nullopt;
}

}  // namespace

TEST(ProduceAhead, GivesEveryResultInOrderThenFinishes) {
  int next = 0;
  ProduceAhead<int> ahead(
      [&next]() -> std::optional<int> {
        if (next == 20) return std::nullopt;
        return next++;
      },
      3, 0);
  for (int expected = 0; expected < 20; ++expected) {
    const std::optional<int> item = takeWaiting(ahead);
    ASSERT_TRUE(item.has_value()) << expected;
    EXPECT_EQ(*item, expected);
  }
  EXPECT_FALSE(takeWaiting(ahead).has_value());
  EXPECT_TRUE(ahead.finished());
  EXPECT_EQ(ahead.error(), "");
}

// Nothing taken: the producer stops `depth` results ahead and waits (also when told to stop).
TEST(ProduceAhead, StaysAtMostDepthAhead) {
  std::atomic<int> produced{0};
  auto reaches = [&produced](int count) {
    for (int i = 0; i < 5000 && produced.load() < count; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    return produced.load() >= count;
  };
  {
    ProduceAhead<int> ahead([&produced]() -> std::optional<int> { return produced++; }, 2, 0);
    ASSERT_TRUE(reaches(2));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));  // time to run past, if it would
    EXPECT_EQ(produced.load(), 2);
    EXPECT_FALSE(ahead.finished());
    ASSERT_TRUE(ahead.tryTake().has_value());
    ASSERT_TRUE(reaches(3));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    EXPECT_EQ(produced.load(), 3);
  }  // the destructor returns while the producer waits for room
  EXPECT_EQ(produced.load(), 3);
}

// With a hold-off the producer starts on the next result no sooner than that after a take.
TEST(ProduceAhead, WaitsTheHoldOffAfterATake) {
  using Clock = std::chrono::steady_clock;
  std::mutex mutex;
  std::vector<Clock::time_point> started;
  ProduceAhead<int> ahead(
      [&]() -> std::optional<int> {
        std::lock_guard<std::mutex> lock(mutex);
        started.push_back(Clock::now());
        return static_cast<int>(started.size());
      },
      1, 0);
  ahead.setHoldOff(std::chrono::milliseconds(60));
  for (int i = 0; i < 3; ++i) {
    const Clock::time_point before_take = Clock::now();
    ASSERT_TRUE(takeWaiting(ahead).has_value());
    ASSERT_TRUE(takeWaiting(ahead).has_value());  // the next one, produced after the hold-off
    std::lock_guard<std::mutex> lock(mutex);
    EXPECT_GE(started.back() - before_take, std::chrono::milliseconds(60)) << i;
  }
}

TEST(ProduceAhead, AnExceptionEndsItWithTheMessage) {
  int calls = 0;
  ProduceAhead<int> ahead(
      [&calls]() -> std::optional<int> {
        if (++calls == 3) throw std::runtime_error("frame 2 failed");
        return calls;
      },
      4, 0);
  EXPECT_EQ(takeWaiting(ahead), std::optional<int>(1));
  EXPECT_EQ(takeWaiting(ahead), std::optional<int>(2));
  EXPECT_FALSE(takeWaiting(ahead).has_value());
  EXPECT_TRUE(ahead.finished());
  EXPECT_EQ(ahead.error(), "frame 2 failed");
}

// The producer runs with its nice value raised, so that the consumer's threads come first.
TEST(ProduceAhead, ProducesAtALowerPriority) {
  const int caller = currentThreadNiceness();
  std::atomic<int> seen{-100};
  ProduceAhead<int> ahead(
      [&seen]() -> std::optional<int> {
        seen = currentThreadNiceness();
        return std::nullopt;
      },
      1, 5);
  EXPECT_FALSE(takeWaiting(ahead).has_value());
#ifdef __linux__
  EXPECT_EQ(seen.load(), std::min(caller + 5, 19));
#endif
}

}  // namespace sag_hand_tracker
