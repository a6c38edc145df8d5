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
  for (const int joint : params.held_joints) {
    if (joint >= 0 && joint < kNumJointDof) steps[kFirstJointDof + joint] = 0.0;
  }
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

PoseAscent::PoseAscent(const PoseEnergy& energy, const Pose& start, const OptimizerParams& params)
    : energy_(&energy), params_(params), steps_(initialSteps(params)) {
  best_.pose = start;
  if (params_.clamp_to_limits) clampToLimits(energy.model(), &best_.pose);
  best_.energy = -std::numeric_limits<double>::infinity();
  pose_ = best_.pose;
  max_steps_ = 4.0 * steps_;
  min_steps_ = 1e-3 * steps_;
  previous_gradient_.setZero();
  best_gradient_.setZero();
}

void PoseAscent::iterate(int iterations) {
  PoseVector gradient;
  for (int i = 0; i < iterations && !stopped_; ++i) {
    const double value = energy_->evaluate(pose_, &gradient);
    ++best_.evaluations;
    ++iterations_;
    if (!std::isfinite(value) || !gradient.allFinite()) {
      stopped_ = true;
      break;
    }
    if (value > best_.energy) {
      best_.energy = value;
      best_.pose = pose_;
      best_gradient_ = gradient;
    } else if (params_.step_control == StepControl::kRprop) {
      // iRprop+: the last step made things worse. Go back to the best pose and step again from
      // there with half the step sizes.
      pose_ = best_.pose;
      gradient = best_gradient_;
      steps_ = (0.5 * steps_).cwiseMax(min_steps_);
      previous_gradient_.setZero();
    }

    PoseVector delta;
    if (params_.step_control == StepControl::kFixed) {
      delta = fixedStep(gradient, steps_);
    } else {
      // Rprop: grow a parameter's step while its gradient keeps its sign, shrink it on a flip.
      delta.setZero();
      for (int k = 0; k < kNumDof; ++k) {
        const double agreement = gradient[k] * previous_gradient_[k];
        if (agreement > 0.0) {
          steps_[k] = std::min(steps_[k] * 1.2, max_steps_[k]);
        } else if (agreement < 0.0) {
          steps_[k] = std::max(steps_[k] * 0.5, min_steps_[k]);
        }
        delta[k] = gradient[k] > 0.0 ? steps_[k] : (gradient[k] < 0.0 ? -steps_[k] : 0.0);
      }
      previous_gradient_ = gradient;
    }
    pose_ = pose_.stepped(delta);
    if (params_.clamp_to_limits) clampToLimits(energy_->model(), &pose_);
  }
}

int PoseAscent::iterateWhileRising(int iterations, int extra, int chunk, double min_gain) {
  if (extra <= 0 || chunk <= 0 || iterations < chunk) {
    iterate(iterations);
    return 0;
  }
  iterate(iterations - chunk);
  int done = 0;
  while (true) {
    const double before = bestEnergy();
    iterate(chunk);
    if (done + chunk > extra || stopped_ || !(bestEnergy() - before > min_gain)) return done;
    done += chunk;
  }
}

OptimizationResult PoseAscent::finish() {
  OptimizationResult best = best_;
  // The last step has not been scored yet.
  const double value = energy_->evaluate(pose_);
  ++best.evaluations;
  if (std::isfinite(value) && value > best.energy) {
    best.energy = value;
    best.pose = pose_;
  }
  if (!std::isfinite(best.energy)) best.energy = 0.0;
  return best;
}

OptimizationResult optimizePose(const PoseEnergy& energy, const Pose& start,
                                const OptimizerParams& params) {
  PoseAscent ascent(energy, start, params);
  ascent.iterate(params.iterations);
  return ascent.finish();
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
