// Per-frame pose optimisation: a fixed number of gradient-ascent iterations (paper section 4.4).
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "sag_hand_tracker/energy/energy.h"
#include "sag_hand_tracker/model/pose.h"

namespace sag_hand_tracker {

enum class StepControl {
  kFixed,  // plain gradient ascent with per-group scaled fixed steps
  kRprop,  // sign-based per-parameter adaptive steps with backtracking (iRprop+), the default
};

StepControl parseStepControl(const std::string& name);  // "fixed" | "rprop"
std::string toString(StepControl step_control);

struct OptimizerParams {
  // Twice the paper's 10: on the studio benchmark (77 runs, doc/history.md "Session 13") 20 took
  // the pooled fingertip error from 15.4 to 14.4 mm and rolled-over frames from 0.4 % to 0.1 %; the
  // float pair kernels (EnergyParams::float_pairs) pay for most of the time. The live tracker
  // keeps 10 (cfg/Tracker.cfg) for its 60 Hz latency.
  int iterations = 20;
  StepControl step_control = StepControl::kRprop;
  // Initial step per parameter group: translation (m), root rotation (rad), joints (rad).
  double translation_step = 0.004;
  double rotation_step = 0.04;
  double joint_step = 0.08;
  bool clamp_to_limits = true;
  // Joints (0..kNumJointDof-1) held where they start: their step is 0.
  std::vector<int> held_joints;
};

struct OptimizationResult {
  Pose pose;
  double energy = 0.0;
  int evaluations = 0;
};

// The ascent of optimizePose, resumable: iterate() runs further iterations, finish() scores the
// last step and gives the best pose met. `energy` must outlive it. Two ascents can so be raced
// (TrackerParams::counter_turn_race_iterations): a few iterations each, then only the better one
// goes on.
class PoseAscent {
 public:
  PoseAscent(const PoseEnergy& energy, const Pose& start, const OptimizerParams& params);
  // Up to `iterations` more iterations (none once an evaluation was not finite).
  void iterate(int iterations);
  // iterate(iterations), then up to `extra` more in chunks of `chunk` while the best energy rose
  // by more than `min_gain` over the last chunk: more iterations only where the ascent is still
  // rising; never more than `extra`. Returns the number of extra iterations run.
  int iterateWhileRising(int iterations, int extra, int chunk, double min_gain);
  int iterations() const { return iterations_; }
  // The best energy scored so far (-infinity before the first iteration).
  double bestEnergy() const { return best_.energy; }
  OptimizationResult finish();

 private:
  const PoseEnergy* energy_;
  OptimizerParams params_;
  OptimizationResult best_;
  Pose pose_;
  PoseVector steps_, max_steps_, min_steps_, previous_gradient_, best_gradient_;
  int iterations_ = 0;
  bool stopped_ = false;
};

// Maximises the energy from `start` with the configured iterations.
OptimizationResult optimizePose(const PoseEnergy& energy, const Pose& start,
                                const OptimizerParams& params);

// The forearm's direction (EnergyParams::forearm_gaussians) that scores `pose` best, with the
// pose fixed: a pattern search from `start` that turns the direction by +-step about two axes
// across it and keeps the best, `rounds` times, halving the step each round. Directions more than
// `max_wrist_angle` (rad) from straight on from the palm (the root's -x axis) are pulled back to
// it. A wrist bends further, but a free arm folds under the hand where it finds the hand's own
// foreground, and the arm's direction needs to be only roughly right: on the studio's
// `wristflex` (flexion up to 55 deg, all hands) 15, 30, 60 and 100 deg gave 13.0, 13.9, 14.2
// and 14.5 mm, the direction fixed at the start's 24.7 mm. Returns the direction; `best_energy`
// (optional) gets its energy (the forearm present). Without forearm Gaussians: `start` (pulled
// back).
struct ForearmSearchParams {
  double initial_step = 0.2;  // rad
  int rounds = 2;
  double max_wrist_angle = 30.0 * M_PI / 180.0;
};
Eigen::Vector3d refineForearmDirection(const PoseEnergy& energy, const Pose& pose,
                                       const Eigen::Vector3d& start,
                                       const ForearmSearchParams& params,
                                       double* best_energy = nullptr);

}  // namespace sag_hand_tracker
