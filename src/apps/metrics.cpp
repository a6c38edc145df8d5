#include "sag_hand_tracker/apps/metrics.h"

#include <cmath>

namespace sag_hand_tracker {

double meanFingertipError(const Fingertips& estimate, const Fingertips& truth) {
  double sum = 0.0;
  for (int f = 0; f < kNumFingers; ++f) sum += (estimate[f] - truth[f]).norm();
  return sum / kNumFingers;
}

ErrorSummary summariseErrors(const std::vector<double>& errors_mm) {
  ErrorSummary summary;
  summary.frames = static_cast<int>(errors_mm.size());
  if (errors_mm.empty()) return summary;
  double sum = 0.0;
  for (double e : errors_mm) sum += e;
  summary.mean_mm = sum / errors_mm.size();
  double squares = 0.0;
  for (double e : errors_mm) squares += (e - summary.mean_mm) * (e - summary.mean_mm);
  summary.sd_mm = std::sqrt(squares / errors_mm.size());
  for (size_t b = 0; b < errorBoundsMm().size(); ++b) {
    int below = 0;
    for (double e : errors_mm) below += e < errorBoundsMm()[b] ? 1 : 0;
    summary.percent_below[b] = 100.0 * below / errors_mm.size();
  }
  return summary;
}

}  // namespace sag_hand_tracker
