#include "sag_hand_tracker/util/thread_pool.h"

namespace sag_hand_tracker {

ThreadPool::ThreadPool(int threads) {
  for (int t = 1; t < threads; ++t) helpers_.emplace_back([this] { helperLoop(); });
}

ThreadPool::~ThreadPool() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  for (std::thread& helper : helpers_) helper.join();
}

void ThreadPool::run(int count, const std::function<void(int)>& body) {
  if (helpers_.empty() || count <= 1) {
    for (int i = 0; i < count; ++i) body(i);
    return;
  }
  std::lock_guard<std::mutex> call(call_mutex_);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    body_ = &body;
    count_ = count;
    next_ = 0;
    error_ = nullptr;
    ++call_;
  }
  wake_.notify_all();
  work();
  std::unique_lock<std::mutex> lock(mutex_);
  // Every index taken and every helper that joined this call out of it.
  done_.wait(lock, [this] { return next_ >= count_ && busy_helpers_ == 0; });
  body_ = nullptr;
  std::exception_ptr error = error_;
  error_ = nullptr;
  lock.unlock();
  if (error) std::rethrow_exception(error);
}

void ThreadPool::work() {
  for (;;) {
    int index;
    const std::function<void(int)>* body;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (next_ >= count_) return;
      index = next_++;
      body = body_;
    }
    try {
      (*body)(index);
    } catch (...) {
      std::lock_guard<std::mutex> lock(mutex_);
      if (!error_) error_ = std::current_exception();
      next_ = count_;  // the remaining indices are skipped
    }
  }
}

void ThreadPool::helperLoop() {
  unsigned long joined = 0;
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return stop_ || (call_ != joined && next_ < count_); });
    if (stop_) return;
    joined = call_;
    ++busy_helpers_;
    lock.unlock();
    work();
    lock.lock();
    --busy_helpers_;
    if (busy_helpers_ == 0) done_.notify_all();
  }
}

}  // namespace sag_hand_tracker
