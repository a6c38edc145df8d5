#include "sag_hand_tracker/optimization/optimizer.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace sag_hand_tracker {
namespace {

// Per-parameter initial step: translation, root rotation, joints.
PoseVector initialSteps(const OptimizerParams& params) {
  PoseVector steps;
  steps.segment<3>(kRootTranslation).setConstant(params.translation_step);
  steps.segment<3>(kRootRotation).setConstant(params.rotation_step);
  steps.segment<kNumJointDof>(kFirstJointDof).setConstant(params.joint_step);
  return steps;
}

// Plain gradient ascent: each group moves by its step along its normalised gradient, so that the
// units (metres, radians) do not need a common scale.
PoseVector fixedStep(const PoseVector& gradient, const PoseVector& steps) {
  PoseVector delta = PoseVector::Zero();
  auto scale_group = [&](int first, int size) {
    const double norm = gradient.segment(first, size).norm();
    if (norm > 0.0)
      delta.segment(first, size) =
          steps.segment(first, size).cwiseProduct(gradient.segment(first, size)) / norm;
  };
  scale_group(kRootTranslation, 3);
  scale_group(kRootRotation, 3);
  scale_group(kFirstJointDof, kNumJointDof);
  return delta;
}

}  // namespace

StepControl parseStepControl(const std::string& name) {
  if (name == "fixed") return StepControl::kFixed;
  if (name == "rprop") return StepControl::kRprop;
  throw InputError("unknown step control '" + name + "' (expected fixed or rprop)");
}

std::string toString(StepControl step_control) {
  return step_control == StepControl::kFixed ? "fixed" : "rprop";
}

OptimizationResult optimizePose(const PoseEnergy& energy, const Pose& start,
                                const OptimizerParams& params) {
  const HandModel& model = energy.model();
  OptimizationResult best;
  best.pose = start;
  if (params.clamp_to_limits) clampToLimits(model, &best.pose);
  best.energy = -std::numeric_limits<double>::infinity();

  Pose pose = best.pose;
  PoseVector steps = initialSteps(params);
  const PoseVector max_steps = 4.0 * steps;
  const PoseVector min_steps = 1e-3 * steps;
  PoseVector previous_gradient = PoseVector::Zero();
  PoseVector gradient;
  int evaluations = 0;

  PoseVector best_gradient = PoseVector::Zero();
  for (int iteration = 0; iteration < params.iterations; ++iteration) {
    const double value = energy.evaluate(pose, &gradient);
    ++evaluations;
    if (!std::isfinite(value) || !gradient.allFinite()) break;
    if (value > best.energy) {
      best.energy = value;
      best.pose = pose;
      best_gradient = gradient;
    } else if (params.step_control == StepControl::kRprop) {
      // iRprop+: the last step made things worse. Go back to the best pose and step again from
      // there with half the step sizes.
      pose = best.pose;
      gradient = best_gradient;
      steps = (0.5 * steps).cwiseMax(min_steps);
      previous_gradient.setZero();
    }

    PoseVector delta;
    if (params.step_control == StepControl::kFixed) {
      delta = fixedStep(gradient, steps);
    } else {
      // Rprop: grow a parameter's step while its gradient keeps its sign, shrink it on a flip.
      delta.setZero();
      for (int i = 0; i < kNumDof; ++i) {
        const double agreement = gradient[i] * previous_gradient[i];
        if (agreement > 0.0) {
          steps[i] = std::min(steps[i] * 1.2, max_steps[i]);
        } else if (agreement < 0.0) {
          steps[i] = std::max(steps[i] * 0.5, min_steps[i]);
        }
        delta[i] = gradient[i] > 0.0 ? steps[i] : (gradient[i] < 0.0 ? -steps[i] : 0.0);
      }
      previous_gradient = gradient;
    }
    pose = pose.stepped(delta);
    if (params.clamp_to_limits) clampToLimits(model, &pose);
  }

  // The last step has not been scored yet.
  const double value = energy.evaluate(pose);
  ++evaluations;
  if (std::isfinite(value) && value > best.energy) {
    best.energy = value;
    best.pose = pose;
  }
  if (!std::isfinite(best.energy)) best.energy = 0.0;
  best.evaluations = evaluations;
  return best;
}

Eigen::Vector3d refineForearmDirection(const PoseEnergy& energy, const Pose& pose,
                                       const Eigen::Vector3d& start,
                                       const ForearmSearchParams& params, double* best_energy) {
  const Eigen::Vector3d straight = -pose.rotation.col(0);
  auto within_wrist = [&](const Eigen::Vector3d& direction) -> Eigen::Vector3d {
    if (!direction.allFinite() || direction.norm() < 1e-9) return straight;
    const Eigen::Vector3d d = direction.normalized();
    const double angle = std::acos(std::clamp(d.dot(straight), -1.0, 1.0));
    if (angle <= params.max_wrist_angle || !(params.max_wrist_angle > 0.0)) return d;
    // Turned back towards straight on, in the plane of the two.
    const Eigen::Vector3d axis = straight.cross(d);
    if (axis.norm() < 1e-9) return straight;  // exactly backwards: nothing to keep
    return Eigen::AngleAxisd(params.max_wrist_angle, axis.normalized()) * straight;
  };
  Eigen::Vector3d best = within_wrist(start);
  double best_value = energy.evaluateWithForearm(pose, best);
  if (energy.params().forearm_gaussians > 0) {
    double step = params.initial_step;
    for (int round = 0; round < params.rounds; ++round, step *= 0.5) {
      const Eigen::Vector3d u = best.unitOrthogonal();
      const Eigen::Vector3d v = best.cross(u);
      const Eigen::Vector3d centre = best;
      for (const Eigen::Vector3d& axis : {u, v}) {
        for (const double sign : {1.0, -1.0}) {
          const Eigen::Vector3d candidate =
              within_wrist(Eigen::AngleAxisd(sign * step, axis) * centre);
          const double value = energy.evaluateWithForearm(pose, candidate);
          if (value > best_value) {
            best_value = value;
            best = candidate;
          }
        }
      }
    }
  }
  if (best_energy) *best_energy = best_value;
  return best;
}

}  // namespace sag_hand_tracker
