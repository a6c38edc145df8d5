// A progress bar for the offline tools, on a stream (stderr). On a terminal it redraws one line
// in place, at most every `min_interval_seconds`; otherwise (a log file, a test) it writes one
// line per 10 % so logs stay readable. No ROS.
#pragma once

#include <chrono>
#include <ostream>
#include <string>

namespace sag_hand_tracker {

class ProgressBar {
 public:
  ProgressBar(std::ostream& out, bool interactive, double min_interval_seconds = 0.1);
  ~ProgressBar();

  // fraction in [0, 1] (clamped); status is a short text after the bar ("frame 12, 5 cameras").
  void update(double fraction, const std::string& status);
  // Draws the final state (100 %) once: ends the line when interactive; when not, writes it
  // unless it is the line just written.
  void finish(const std::string& status);

  // The text of the bar line for a fraction: "[#####     ]  50% status".
  static std::string render(double fraction, const std::string& status, int width = 30);

 private:
  std::ostream& out_;
  bool interactive_;
  double min_interval_seconds_;
  std::chrono::steady_clock::time_point last_draw_;
  bool drawn_ = false;
  bool finished_ = false;
  int last_decile_ = -1;
  std::size_t last_length_ = 0;
  std::string last_line_;  // not interactive: the last line written
};

// Whether stderr is a terminal (for ProgressBar's `interactive`).
bool stderrIsTerminal();

}  // namespace sag_hand_tracker
