// Groups per-camera messages of N cameras into sets by their stamp, for the live tracker
// (message_filters' synchronizers stop at 9 inputs and cannot leave out a camera that stopped).
// ROS-free: stamps are integer nanoseconds, the clock is passed in, so every rule is unit-tested.
//
// Rules (doc/design.md section 5):
// - A message joins the pending set of its stamp, or else the nearest one within `stamp_tolerance`
//   that this camera has not delivered to (cameras that are not stamped together); the set keeps
//   its first message's stamp.
// - A set is ready as soon as every camera that is not marked missing has delivered for its stamp;
//   the newest ready set is released and older incomplete sets are dropped (counted).
// - A set still incomplete `camera_timeout` seconds after its first message is released with the
//   cameras present; the absent ones are marked missing (not waited for) until they deliver again.
// - A message for a stamp at or before the last released one is late and ignored (counted), unless
//   it is more than `time_jump_threshold` older: then time jumped back (a bag loop) and everything
//   is reset. The same reset happens when the clock given to checkClock jumps back.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace sag_hand_tracker {

struct CameraSetSynchronizerParams {
  int num_cameras = 5;
  double camera_timeout = 0.5;       // seconds of the wall clock given to add/poll
  double time_jump_threshold = 1.0;  // seconds of stamp (or clock) time
  // Messages of different cameras whose stamps differ by at most this (seconds) are one set; 0:
  // identical stamps only. Below half the frame period (5 ms: rigs up to 100 fps).
  double stamp_tolerance = 0.005;
};

// Something the owner may want to log; each comes once, when it happens.
struct SyncEvent {
  enum class Kind {
    kCameraMissing,  // `camera` delivered nothing for a set within camera_timeout
    kCameraBack,     // `camera` delivers again after being missing
    kLate,           // a message of `camera` older than the last released set was ignored
    kTimeJumpBack,   // stamps or the clock jumped back by `seconds`: everything was reset
  };
  Kind kind = Kind::kLate;
  int camera = -1;       // -1 when not about one camera
  double seconds = 0.0;  // kTimeJumpBack: how far back; kLate: how much older than the last set
};

struct SyncStatistics {
  long released_sets = 0;
  long dropped_sets = 0;  // incomplete sets overtaken by a newer complete one
  long late_messages = 0;
  long resets = 0;
  long tolerated_stamps = 0;  // messages that joined a set of another stamp (stamp_tolerance)
};

// The set an item of a camera stamped `stamp_ns` joins in `sets` (stamp -> set): the one of that
// very stamp if there is one, else the nearest within `tolerance_ns` for which `lacks_camera` is
// true; sets.end() when there is none. The grouping rule of the live synchronizer and of the bag
// reader (ros/bag_input.h).
template <typename Map, typename LacksCamera>
typename Map::iterator setWithinTolerance(Map& sets, std::int64_t stamp_ns,
                                          std::int64_t tolerance_ns, LacksCamera lacks_camera) {
  const auto exact = sets.find(stamp_ns);
  if (exact != sets.end() || tolerance_ns <= 0) return exact;
  const auto distance = [stamp_ns](std::int64_t other) {
    return other > stamp_ns ? other - stamp_ns : stamp_ns - other;
  };
  auto best = sets.end();
  for (auto it = sets.lower_bound(stamp_ns - tolerance_ns);
       it != sets.end() && it->first <= stamp_ns + tolerance_ns; ++it) {
    if (!lacks_camera(it->second)) continue;
    if (best == sets.end() || distance(it->first) < distance(best->first)) best = it;
  }
  return best;
}

// The stamp tolerance in ns; 0 for values outside (0, 1] s.
inline std::int64_t toleranceNs(double seconds) {
  return seconds > 0.0 && seconds <= 1.0 ? static_cast<std::int64_t>(std::llround(seconds * 1e9))
                                         : 0;
}

template <typename Message>
class CameraSetSynchronizer {
 public:
  struct Set {
    std::int64_t stamp_ns = 0;
    std::vector<std::optional<Message>> messages;  // per camera; empty: not delivered
    int count() const {
      int n = 0;
      for (const auto& m : messages) n += m ? 1 : 0;
      return n;
    }
  };

  explicit CameraSetSynchronizer(const CameraSetSynchronizerParams& params)
      : params_(params), missing_(static_cast<size_t>(std::max(params.num_cameras, 0)), false) {}

  // One message of `camera` (0..num_cameras-1) stamped `stamp_ns`, received at `wall_seconds`.
  // Returns the set it completed, if any. A second message of the same camera and stamp replaces
  // the first. Throws std::out_of_range for a camera index outside the range.
  std::optional<Set> add(int camera, std::int64_t stamp_ns, Message message, double wall_seconds) {
    if (camera < 0 || camera >= params_.num_cameras) {
      throw std::out_of_range("camera index " + std::to_string(camera) + " outside 0.." +
                              std::to_string(params_.num_cameras - 1));
    }
    if (missing_[camera]) {
      missing_[camera] = false;
      events_.push_back({SyncEvent::Kind::kCameraBack, camera, 0.0});
    }
    if (last_released_ && stamp_ns <= *last_released_) {
      const double back = 1e-9 * static_cast<double>(*last_released_ - stamp_ns);
      if (back > params_.time_jump_threshold) {
        resetAfterJump(back);
      } else {
        ++statistics_.late_messages;
        events_.push_back({SyncEvent::Kind::kLate, camera, back});
        return std::nullopt;
      }
    }
    Pending& pending = pendingFor(camera, stamp_ns);
    if (pending.set.messages.empty()) {
      pending.set.stamp_ns = stamp_ns;
      pending.set.messages.resize(params_.num_cameras);
      pending.first_arrival = wall_seconds;
    }
    pending.set.messages[camera] = std::move(message);
    return releaseNewestComplete();
  }

  // Releases, oldest first, the sets whose cameras timed out at `wall_seconds`, marking the
  // cameras that did not deliver as missing; then the newest set that this made complete.
  std::vector<Set> poll(double wall_seconds) {
    std::vector<Set> released;
    while (!pending_.empty()) {
      auto oldest = pending_.begin();
      if (wall_seconds - oldest->second.first_arrival < params_.camera_timeout) break;
      for (int i = 0; i < params_.num_cameras; ++i) {
        if (!oldest->second.set.messages[i] && !missing_[i]) {
          missing_[i] = true;
          events_.push_back({SyncEvent::Kind::kCameraMissing, i, params_.camera_timeout});
        }
      }
      released.push_back(std::move(oldest->second.set));
      pending_.erase(oldest);
      markReleased(released.back().stamp_ns);
    }
    // A camera marked missing now may have completed a newer set: no need to wait for it.
    if (std::optional<Set> set = releaseNewestComplete()) released.push_back(std::move(*set));
    return released;
  }

  // The owner's clock (e.g. ROS time, which a looping bag sets back). Returns true when it jumped
  // back by more than time_jump_threshold since the last call: everything has then been reset.
  bool checkClock(double now_seconds) {
    const bool jumped = last_clock_ && now_seconds + params_.time_jump_threshold < *last_clock_;
    if (jumped) resetAfterJump(*last_clock_ - now_seconds);
    last_clock_ = now_seconds;
    return jumped;
  }

  // Forgets the pending sets and the last released stamp (missing cameras stay missing).
  void reset() {
    pending_.clear();
    last_released_.reset();
  }

  // The events since the last call.
  std::vector<SyncEvent> takeEvents() { return std::exchange(events_, {}); }

  bool isMissing(int camera) const { return missing_.at(camera); }
  int missingCount() const {
    int n = 0;
    for (bool m : missing_) n += m ? 1 : 0;
    return n;
  }
  size_t pendingCount() const { return pending_.size(); }
  const SyncStatistics& statistics() const { return statistics_; }
  const CameraSetSynchronizerParams& params() const { return params_; }

 private:
  struct Pending {
    Set set;
    double first_arrival = 0.0;
  };

  // The pending set of `stamp_ns`, else the nearest within the stamp tolerance without a message
  // of `camera`, else a new one.
  Pending& pendingFor(int camera, std::int64_t stamp_ns) {
    const auto found =
        setWithinTolerance(pending_, stamp_ns, toleranceNs(params_.stamp_tolerance),
                           [camera](const Pending& p) { return !p.set.messages[camera]; });
    if (found == pending_.end()) return pending_[stamp_ns];
    if (found->first != stamp_ns) ++statistics_.tolerated_stamps;
    return found->second;
  }

  bool isComplete(const Set& set) const {
    for (int i = 0; i < params_.num_cameras; ++i) {
      if (!missing_[i] && !set.messages[i]) return false;
    }
    return set.count() > 0;
  }

  std::optional<Set> releaseNewestComplete() {
    for (auto it = pending_.rbegin(); it != pending_.rend(); ++it) {
      if (!isComplete(it->second.set)) continue;
      Set set = std::move(it->second.set);
      const auto end = pending_.upper_bound(set.stamp_ns);
      for (auto older = pending_.begin(); older != end; ++older) {
        if (older->first != set.stamp_ns) ++statistics_.dropped_sets;
      }
      pending_.erase(pending_.begin(), end);
      markReleased(set.stamp_ns);
      return set;
    }
    return std::nullopt;
  }

  void markReleased(std::int64_t stamp_ns) {
    last_released_ = stamp_ns;
    ++statistics_.released_sets;
  }

  void resetAfterJump(double seconds) {
    reset();
    ++statistics_.resets;
    events_.push_back({SyncEvent::Kind::kTimeJumpBack, -1, seconds});
  }

  CameraSetSynchronizerParams params_;
  std::vector<bool> missing_;
  std::map<std::int64_t, Pending> pending_;
  std::optional<std::int64_t> last_released_;
  std::optional<double> last_clock_;
  std::vector<SyncEvent> events_;
  SyncStatistics statistics_;
};

}  // namespace sag_hand_tracker
