// Which hand is in view, left or right, decided by the images: the first sets with a hand are
// tracked twice, with the model as given and mirrored, and the hand whose tracks explain the images
// better is kept (track_bag --hand auto). A mirrored model on a hand of the other side ends 37-76
// mm off in the studio, every frame still "tracked", and scores lower in most frames
// (doc/studio.md, "Left hands").
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/tracking/frame_set.h"
#include "sag_hand_tracker/tracking/tracking_pipeline.h"

namespace sag_hand_tracker {

struct HandednessParams {
  // Sets in which both hands have a tracked pose (not lost) over which the energies are compared:
  // one second at 25 frames/s. The choice is the sign of the median of the per-set differences
  // (right - left), which a few bad frames at the start do not decide: on the studio's 84
  // right-hand bags and 8 left-hand bags the median over 25 sets chose right every time, the mean
  // chose wrong once (fastturn, dark_small: a start that needed a few frames).
  int decision_sets = 25;
  // Read no more than this many sets with images of the hand (after the background frames) for
  // the decision, so that a recording without the hand is not tracked twice to its end.
  int max_sets = 250;
  // A median difference below this is reported as close: on the studio's right hands it ranged
  // down to 0.0004 (left hands: 0.012-0.022).
  double close_margin = 0.003;
};
// Throws InputError naming the first bad parameter.
void validate(const HandednessParams& params);

struct HandednessDecision {
  Handedness hand = Handedness::kRight;
  bool decided = false;  // false: no set where both hands had a pose; `hand` is the model's own
  bool close = false;    // |median_difference| < close_margin
  int sets = 0;          // sets where both hands had a pose (compared)
  double right_energy = 0.0;       // mean energy of the right hand's tracked poses over those sets
  double left_energy = 0.0;        // the same for the left hand
  double median_difference = 0.0;  // median over those sets of right - left energy
  int right_higher = 0;            // of those sets, where the right hand scored higher
};

// Tracks the sets that `next_set` gives (false: no more) with `model` as a right and as a left hand
// (two TrackingPipelines with `params`) until decision_sets sets have a pose in both or max_sets
// sets were tracked, and chooses by the median difference of their energies. Throws what the
// pipelines throw (InputError for a set that does not fit the cameras).
HandednessDecision decideHandedness(const HandModel& model, const std::vector<Camera>& cameras,
                                    const PipelineParams& params,
                                    const std::function<bool(FrameSet*)>& next_set,
                                    const HandednessParams& handedness = HandednessParams());

// "left (higher than a right hand in 25 of 25 sets, by 0.021 in the median; mean energy 0.683
// against 0.662)", with "; close: give --hand if you know" when close, or why there was no
// decision.
std::string handednessText(const HandednessDecision& decision);

}  // namespace sag_hand_tracker
