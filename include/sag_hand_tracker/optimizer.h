// Per-frame pose optimisation: a fixed number of gradient-ascent iterations (paper section 4.4).
#pragma once

#include <string>

#include "sag_hand_tracker/energy.h"
#include "sag_hand_tracker/pose.h"

namespace sag_hand_tracker {

enum class StepControl {
  kFixed,  // plain gradient ascent with per-group scaled fixed steps
  kRprop,  // sign-based per-parameter adaptive steps with backtracking (iRprop+), the default
};

StepControl parseStepControl(const std::string& name);  // "fixed" | "rprop"
std::string toString(StepControl step_control);

struct OptimizerParams {
  int iterations = 10;  // the paper's 10 iterations per frame
  StepControl step_control = StepControl::kRprop;
  // Initial step per parameter group: translation (m), root rotation (rad), joints (rad).
  double translation_step = 0.004;
  double rotation_step = 0.04;
  double joint_step = 0.08;
  bool clamp_to_limits = true;
};

struct OptimizationResult {
  Pose pose;
  double energy = 0.0;
  int evaluations = 0;
};

// Maximises the energy from `start` with the configured iterations.
OptimizationResult optimizePose(const PoseEnergy& energy, const Pose& start,
                                const OptimizerParams& params);

}  // namespace sag_hand_tracker
