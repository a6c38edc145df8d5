// Wall-clock durations for the figures the tools and the pipeline report (not for control flow).
#pragma once

#include <chrono>
#include "sag_hand_tracker/util/timing.h"

namespace sag_hand_tracker {

// Seconds from `start` to now, on the monotonic clock.
inline }  // namespace sag_hand_tracker
