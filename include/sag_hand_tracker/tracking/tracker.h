// The tracker: per frame, image SoGs of N cameras -> optimised hand pose, with warm start,
// automatic start (no manual initial pose) and restart when the track is lost.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "sag_hand_tracker/energy/energy.h"
#include "sag_hand_tracker/optimization/optimizer.h"

namespace sag_hand_tracker {

enum class TrackStatus {
  kWaiting,   // no hand seen yet (or not enough foreground in the cameras)
  kStarted,   // this frame started (or restarted) the track from hypotheses
  kTracking,  // warm-started from the previous frames
  kLost,      // the energy says the track is lost; the next frame restarts
};
std::string toString(TrackStatus status);

struct TrackerParams {
  EnergyParams energy;
  OptimizerParams optimizer;
  // Automatic start: minimum number of image Gaussians in a camera to count it as seeing the hand,
  // and in how many cameras that must hold.
  int min_foreground_gaussians = 8;
  int min_cameras_for_start = 2;
  // Iterations spent on each start hypothesis.
  int start_iterations = 40;
  // Every this many tracked frames, the start routine runs as well and replaces the tracked pose
  // when it finds a clearly better one (energy higher by `redetect_margin`); 0 disables it. This
  // recovers tracks that converged to a wrong but stable pose, which the similarity cannot flag.
  int redetect_interval = 25;
  double redetect_margin = 0.005;
  // The track counts as lost when the normalised similarity drops below `lost_similarity`, or
  // below `lost_ratio` times its running average over the recent tracked frames.
  double lost_similarity = 0.15;
  double lost_ratio = 0.7;
};

struct FrameResult {
  double stamp = 0.0;
  TrackStatus status = TrackStatus::kWaiting;
  bool has_pose = false;  // false while waiting: pose and fingertips are then meaningless
  Pose pose;
  Fingertips fingertips;
  EnergyTerms energy;
  int num_cameras = 0;
  bool restarted = false;  // the track had been lost and was started again in this frame
};

class HandTracker {
 public:
  HandTracker(const HandModel& model, const TrackerParams& params);

  // One synchronized set: the cameras that delivered, each with its foreground image SoG
  // (undistorted pixels). Missing cameras are simply absent.
  FrameResult update(const std::vector<CameraObservation>& observations, double stamp);

  void reset();
  const HandModel& model() const { return model_; }
  const TrackerParams& params() const { return params_; }
  void setParams(const TrackerParams& params);

 private:
  // Automatic start: triangulate the foreground, score open-hand orientation hypotheses there,
  // refine the best few. Empty when too few cameras see the hand.
  std::optional<OptimizationResult> startFromHypotheses(
      const PoseEnergy& energy, const std::vector<CameraObservation>& observations) const;

  HandModel model_;
  TrackerParams params_;
  PoseEnergy energy_;  // the frame's energy; rebuilt only when the parameters change
  std::optional<Pose> previous_;
  std::optional<Pose> current_;
  bool lost_ = false;
  double typical_similarity_ = 0.0;  // running average while tracking (0: none yet)
  int frames_since_start_ = 0;
  bool looksLost(double similarity) const;
};

}  // namespace sag_hand_tracker
