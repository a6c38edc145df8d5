// One warning per camera and kind of problem per period, so that a flood of one problem neither
// fills the log nor hides another camera's or another problem's warning (a single throttled call
// site would).
#pragma once

#include <ros/time.h>

#include <map>
#include <string>
#include <utility>

namespace sag_hand_tracker {

class ThrottledWarnings {
 public:
  explicit ThrottledWarnings(double period_seconds = 5.0) : period_(period_seconds) {}

  // True when `problem` of `camera` (-1: not about one camera) was not warned about in the last
  // period; the kind of problem is the text up to its first digit or quote, so that messages that
  // differ only in numbers or names count as one.
  bool shouldWarn(int camera, const std::string& problem, ros::WallTime now = ros::WallTime::now());

 private:
  double period_;
  std::map<std::pair<int, std::string>, ros::WallTime> last_;
};

}  // namespace sag_hand_tracker
