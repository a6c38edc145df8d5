// Accuracy metrics of the paper's evaluation (section 5): fingertip error per frame, its mean and
// standard deviation, and the percentage of frames below error bounds (Table 1); and the global
// orientation failures of issue 9: reversed hands (wrist and fingertips swapped), rolled-over
// hands (palm where the back of the hand is) and the wrist (root position) error.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <vector>

#include "sag_hand_tracker/model/hand_model.h"
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

// How far a tracked hand's global placement is from the truth's, from the root parameters only
// (rotation palm frame -> root frame, wrist position).
struct OrientationError {
  // Angle between the tracked and the true wrist -> middle-knuckle directions (degrees).
  double forward_deg = 0.0;
  // Angle between the tracked and the true back-of-hand normals, the palm frames' z axes.
  double back_normal_deg = 0.0;
  // Distance between the tracked and the true wrist (root position), metres.
  double wrist_m = 0.0;
  // The failure kinds: an axis more than 90 degrees from the truth's. NaN angles (a
  // non-finite pose) count as failures of both kinds.
  bool reversed() const { return !(forward_deg <= 90.0); }
  bool rolledOver() const { return !(back_normal_deg <= 90.0); }
};

// `forward_in_palm` is the wrist -> middle-knuckle direction in the palm frame (the middle finger's
// first bone offset, see middleKnuckleDirection; any non-zero length). Both rotations are palm
// frame -> root frame.
OrientationError orientationError(
    const Eigen::Matrix3d& estimate_rotation, const Eigen::Vector3d& estimate_wrist,
    const Eigen::Matrix3d& truth_rotation, const Eigen::Vector3d& truth_wrist,
    const Eigen::Vector3d& forward_in_palm = Eigen::Vector3d::UnitX());

// The wrist -> middle-knuckle direction of `model` in its palm frame (unit): the offset of the
// middle finger's first bone (found from its fingertip Gaussian's bone). The palm's x axis if the
// model has no such chain.
Eigen::Vector3d middleKnuckleDirection(const HandModel& model);

// Angle between two directions in degrees (0..180); NaN if either is zero or not finite.
double angleBetweenDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

}  // namespace sag_hand_tracker
