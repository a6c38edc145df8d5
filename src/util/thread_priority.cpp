#include "sag_hand_tracker/util/thread_priority.h"

#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#endif

namespace sag_hand_tracker {

#ifdef __linux__
namespace {
// On Linux the nice value belongs to each thread (task): setpriority with the thread id changes
// only the calling thread, not the process.
id_t currentThreadId() { return static_cast<id_t>(syscall(SYS_gettid)); }
}  // namespace

int currentThreadNiceness() {
  errno = 0;
  const int niceness = getpriority(PRIO_PROCESS, currentThreadId());
  return errno == 0 ? niceness : 0;
}

bool lowerCurrentThreadPriority(int increment) {
  if (increment <= 0) return true;
  const int target = currentThreadNiceness() + increment;
  return setpriority(PRIO_PROCESS, currentThreadId(), target > 19 ? 19 : target) == 0;
}
#else
int currentThreadNiceness() { return 0; }
bool lowerCurrentThreadPriority(int increment) { return increment <= 0; }
#endif

}  // namespace sag_hand_tracker
