#include "sag_hand_tracker/apps/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>

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

double angleBetweenDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double na = a.norm(), nb = b.norm();
  if (!(na > 0.0) || !(nb > 0.0) || !std::isfinite(na) || !std::isfinite(nb)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  // atan2 of |a x b| and a . b: accurate near 0 and 180 degrees, where acos is not.
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / M_PI;
}

Eigen::Vector3d middleKnuckleDirection(const HandModel& model) {
  const int g = model.fingertip_gaussians[2];  // the middle finger
  if (g < 0 || g >= static_cast<int>(model.gaussians.size())) return Eigen::Vector3d::UnitX();
  int bone = model.gaussians[g].bone;
  for (int steps = 0; bone > 0 && steps < 8; ++steps) {
    if (bone >= static_cast<int>(model.bones.size())) break;
    if (model.bones[bone].parent == 0) {
      const Eigen::Vector3d offset = model.bones[bone].offset;
      return offset.norm() > 0.0 ? offset.normalized() : Eigen::Vector3d::UnitX();
    }
    bone = model.bones[bone].parent;
  }
  return Eigen::Vector3d::UnitX();
}

OrientationError orientationError(const Eigen::Matrix3d& estimate_rotation,
                                  const Eigen::Vector3d& estimate_wrist,
                                  const Eigen::Matrix3d& truth_rotation,
                                  const Eigen::Vector3d& truth_wrist,
                                  const Eigen::Vector3d& forward_in_palm) {
  OrientationError error;
  error.forward_deg =
      angleBetweenDeg(estimate_rotation * forward_in_palm, truth_rotation * forward_in_palm);
  error.back_normal_deg = angleBetweenDeg(estimate_rotation.col(2), truth_rotation.col(2));
  error.wrist_m = (estimate_wrist - truth_wrist).norm();
  return error;
}

}  // namespace sag_hand_tracker
