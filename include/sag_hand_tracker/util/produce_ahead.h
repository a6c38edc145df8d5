// Work produced ahead of its use on a thread of lower priority: the studio driver renders its
// camera sets here, so that the timer publishes them at a steady rate and the rendering takes the
// CPU only when the tracking graph leaves it (a real camera costs the host no CPU; issue 12).
#pragma once

#include <chrono>
#include <condition_variable>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "sag_hand_tracker/util/thread_priority.h"

namespace sag_hand_tracker {

template <typename T>
class ProduceAhead {
 public:
  // Calls `produce` on a thread of its own, its nice value raised by `niceness`
  // (lowerCurrentThreadPriority; threads it starts inherit it), in order, keeping at most `depth`
  // (>= 1) results not yet taken; `produce` returning nothing ends it, and so does an exception
  // (error()).
  ProduceAhead(std::function<std::optional<T>()> produce, int depth, int niceness)
      : produce_(std::move(produce)), depth_(depth < 1 ? 1 : depth), niceness_(niceness) {
    thread_ = std::thread([this] { loop(); });
  }
  // Stops after the item being produced, which is dropped.
  ~ProduceAhead() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    room_.notify_all();
    thread_.join();
  }
  ProduceAhead(const ProduceAhead&) = delete;
  ProduceAhead& operator=(const ProduceAhead&) = delete;

  // After each take, the producer waits this long before it starts on the next result (0: at
  // once). For a consumer that takes at a steady rate and then works on what it took: a hold-off
  // of (period - production time) keeps the production out of that work, while the results still
  // ahead cover a production that runs long.
  void setHoldOff(std::chrono::steady_clock::duration hold_off) {
    std::lock_guard<std::mutex> lock(mutex_);
    hold_off_ = hold_off;
  }

  // The next result if it is ready; never waits.
  std::optional<T> tryTake() {
    std::optional<T> item;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (ready_.empty()) return std::nullopt;
      item = std::move(ready_.front());
      ready_.pop_front();
      last_take_ = std::chrono::steady_clock::now();
    }
    room_.notify_all();
    return item;
  }
  // The producer has ended (nothing more to come) and every result has been taken.
  bool finished() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return ended_ && ready_.empty();
  }
  // What ended the producer, if it threw ("" otherwise).
  std::string error() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return error_;
  }

 private:
  void loop() {
    lowerCurrentThreadPriority(niceness_);  // best effort, as the tracker's searches
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        room_.wait(lock, [this] { return stop_ || static_cast<int>(ready_.size()) < depth_; });
        if (stop_) break;
        if (room_.wait_until(lock, last_take_ + hold_off_, [this] { return stop_; })) break;
      }
      std::optional<T> item;
      std::string error;
      try {
        item = produce_();
      } catch (const std::exception& e) {
        error = e.what();
      } catch (...) {
        error = "unknown exception";
      }
      std::lock_guard<std::mutex> lock(mutex_);
      if (!item) {
        error_ = error;
        break;
      }
      ready_.push_back(std::move(*item));
    }
    std::lock_guard<std::mutex> lock(mutex_);
    ended_ = true;
  }

  std::function<std::optional<T>()> produce_;
  const int depth_;
  const int niceness_;
  mutable std::mutex mutex_;
  std::condition_variable room_;
  std::deque<T> ready_;
  bool stop_ = false;
  bool ended_ = false;
  std::string error_;
  std::chrono::steady_clock::duration hold_off_{0};
  std::chrono::steady_clock::time_point last_take_{};
  std::thread thread_;  // last: started once the rest is set up
};

}  // namespace sag_hand_tracker
