#include "sag_hand_tracker/apps/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace sag_hand_tracker {

ProgressBar::ProgressBar(std::ostream& out, bool interactive, double min_interval_seconds)
    : out_(out), interactive_(interactive), min_interval_seconds_(min_interval_seconds) {}

ProgressBar::~ProgressBar() {
  // An unfinished interactive bar (an exception left the loop) must not swallow the next line.
  if (interactive_ && drawn_ && !finished_) out_ << '\n' << std::flush;
}

std::string ProgressBar::render(double fraction, const std::string& status, int width) {
  fraction = std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0);
  const int filled = static_cast<int>(std::floor(fraction * width + 1e-9));
  char percent[8];
  std::snprintf(percent, sizeof(percent), "%3d%%", static_cast<int>(std::floor(fraction * 100.0)));
  std::string line = "[" + std::string(filled, '#') + std::string(width - filled, ' ') + "] ";
  line += percent;
  if (!status.empty()) line += " " + status;
  return line;
}

void ProgressBar::update(double fraction, const std::string& status) {
  if (finished_) return;
  fraction = std::clamp(std::isfinite(fraction) ? fraction : 0.0, 0.0, 1.0);
  const auto now = std::chrono::steady_clock::now();
  if (interactive_) {
    if (drawn_ && std::chrono::duration<double>(now - last_draw_).count() < min_interval_seconds_) {
      return;
    }
    const std::string line = render(fraction, status);
    // Pad over the remains of a longer previous line.
    const std::size_t pad = last_length_ > line.size() ? last_length_ - line.size() : 0;
    out_ << '\r' << line << std::string(pad, ' ') << std::flush;
    last_length_ = line.size();
  } else {
    const int decile = static_cast<int>(std::floor(fraction * 10.0 + 1e-9));
    if (decile <= last_decile_) return;
    last_line_ = render(fraction, status);
    out_ << last_line_ << '\n' << std::flush;
    last_decile_ = decile;
  }
  last_draw_ = now;
  drawn_ = true;
}

void ProgressBar::finish(const std::string& status) {
  if (finished_) return;
  if (interactive_) {
    drawn_ = false;  // draw now, whatever the interval
    update(1.0, status);
    out_ << '\n' << std::flush;
  } else if (render(1.0, status) != last_line_) {
    out_ << render(1.0, status) << '\n' << std::flush;
  }
  finished_ = true;
}

bool stderrIsTerminal() { return isatty(STDERR_FILENO) == 1; }

}  // namespace sag_hand_tracker
