// parallelFor on threads that stay: for work done again and again (the studio's views, frame
// after frame), where starting threads each time costs, and their thread_local buffers, reused
// from call to call on a kept thread, would otherwise be allocated and faulted in every time.
#pragma once

#include <condition_variable>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace sag_hand_tracker {

class ThreadPool {
 public:
  // `threads` - 1 helper threads (the caller of run is the other one); threads <= 1: none, and
  // run is a plain loop.
  explicit ThreadPool(int threads);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  // parallelFor's contract (util/parallel_for.h): body(i) once for every i in [0, count), the
  // order not fixed, the first exception rethrown after every thread has stopped. Calls from
  // several threads take turns.
  void run(int count, const std::function<void(int)>& body);
  int threads() const { return static_cast<int>(helpers_.size()) + 1; }

 private:
  void helperLoop();
  void work();  // takes indices of the current call until none is left; caller holds no lock

  std::mutex call_mutex_;  // one run at a time
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(int)>* body_ = nullptr;
  int count_ = 0;
  int next_ = 0;
  int busy_helpers_ = 0;
  unsigned long call_ = 0;  // which call the helpers last joined
  bool stop_ = false;
  std::exception_ptr error_;
  std::vector<std::thread> helpers_;
};

}  // namespace sag_hand_tracker
