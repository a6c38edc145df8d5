#include "sag_hand_tracker/ros/throttled_warnings.h"

namespace sag_hand_tracker {

bool ThrottledWarnings::shouldWarn(int camera, const std::string& problem, ros::WallTime now) {
  const std::string kind = problem.substr(0, problem.find_first_of("0123456789'\""));
  const auto key = std::make_pair(camera, kind);
  const auto last = last_.find(key);
  if (last != last_.end() && (now - last->second).toSec() < period_) return false;
  last_[key] = now;
  return true;
}

}  // namespace sag_hand_tracker
