#include "sag_hand_tracker/util/parallel_for.h"

#include <algorithm>

#include "sag_hand_tracker/util/thread_pool.h"

namespace sag_hand_tracker {

void parallelFor(int count, int threads, const std::function<void(int)>& body) {
  // A pool for this call only: its helpers are started here, so they take this thread's nice value.
  ThreadPool(std::min(threads, count)).run(count, body);
}

}  // namespace sag_hand_tracker
