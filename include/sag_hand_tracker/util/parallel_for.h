// Independent work items spread over a few threads: the start's hypothesis search (issue 12),
// whose candidates are scored and refined independently of each other.
#pragma once

#include <functional>

namespace sag_hand_tracker {

// Calls `body(i)` once for every i in [0, count), on up to `threads` threads: the calling thread
// and `threads - 1` new ones, each taking the next index until none is left. New threads start at
// the calling thread's nice value (Linux), so a lowered worker's helpers stay lowered. The order of
// the calls is not fixed: `body` must touch only what belongs to its index (then the result does
// not depend on `threads`). The first exception thrown by a call is rethrown here after all
// threads have ended; the remaining indices are then skipped. threads <= 1: a plain loop.
// A ThreadPool (util/thread_pool.h) made for the call: for work repeated frame after frame, keep
// a pool instead.
void parallelFor(int count, int threads, const std::function<void(int)>& body);

}  // namespace sag_hand_tracker
