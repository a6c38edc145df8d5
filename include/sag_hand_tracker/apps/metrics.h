// Accuracy metrics of the paper's evaluation (section 5): fingertip error per frame, its mean and
// standard deviation, and the percentage of frames below error bounds (Table 1).
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

#include "sag_hand_tracker/model/kinematics.h"

namespace sag_hand_tracker {

// Mean over the five fingertips of the Euclidean distance (metres).
double meanFingertipError(const Fingertips& estimate, const Fingertips& truth);

// The paper's error bounds for Table 1 (mm).
inline const std::array<double, 5>& errorBoundsMm() {
  static const std::array<double, 5> bounds{{15.0, 20.0, 25.0, 30.0, 45.0}};
  return bounds;
}

struct ErrorSummary {
  int frames = 0;
  double mean_mm = 0.0;
  double sd_mm = 0.0;
  std::array<double, 5> percent_below{};  // per errorBoundsMm()
};

// Summary of per-frame errors given in millimetres.
ErrorSummary summariseErrors(const std::vector<double>& errors_mm);

}  // namespace sag_hand_tracker
