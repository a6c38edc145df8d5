// Wall-clock durations for the figures the tools and the pipeline report (not for control flow).
#pragma once

#include <chrono>

namespace sag_hand_tracker {

// Seconds from `start` to now, on the monotonic clock.
inline double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace sag_hand_tracker
