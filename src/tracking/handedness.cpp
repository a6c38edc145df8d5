#include "sag_hand_tracker/tracking/handedness.h"

#include <algorithm>
#include <cmath>

#include "sag_hand_tracker/util/number_text.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

void validate(const HandednessParams& params) {
  if (params.decision_sets < 1) throw InputError("handedness: decision_sets must be >= 1");
  if (params.max_sets < params.decision_sets) {
    throw InputError("handedness: max_sets must be >= decision_sets");
  }
  if (!(params.close_margin >= 0.0)) throw InputError("handedness: close_margin must be >= 0");
}

HandednessDecision decideHandedness(const HandModel& model, const std::vector<Camera>& cameras,
                                    const PipelineParams& params,
                                    const std::function<bool(FrameSet*)>& next_set,
                                    const HandednessParams& handedness) {
  validate(handedness);
  const HandModel right = model.handedness == Handedness::kRight ? model : mirrorHandModel(model);
  const HandModel left = mirrorHandModel(right);
  TrackingPipeline right_pipeline(right, cameras, params);
  TrackingPipeline left_pipeline(left, cameras, params);
  HandednessDecision decision;
  decision.hand = model.handedness;
  double right_sum = 0.0, left_sum = 0.0;
  std::vector<double> differences;  // right - left, per compared set
  int tracked_sets = 0;
  FrameSet set;
  while (decision.sets < handedness.decision_sets && tracked_sets < handedness.max_sets &&
         next_set(&set)) {
    const ProcessedFrame r = right_pipeline.process(set);
    const ProcessedFrame l = left_pipeline.process(set);
    if (r.background) continue;
    ++tracked_sets;
    auto posed = [](const FrameResult& result) {
      return result.has_pose && result.status != TrackStatus::kLost;
    };
    if (!posed(r.result) || !posed(l.result)) continue;
    ++decision.sets;
    right_sum += r.result.energy.total;
    left_sum += l.result.energy.total;
    differences.push_back(r.result.energy.total - l.result.energy.total);
    if (differences.back() > 0.0) ++decision.right_higher;
  }
  if (decision.sets == 0) return decision;
  decision.decided = true;
  decision.right_energy = right_sum / decision.sets;
  decision.left_energy = left_sum / decision.sets;
  const size_t half = differences.size() / 2;
  std::nth_element(differences.begin(), differences.begin() + half, differences.end());
  decision.median_difference = differences[half];
  if (differences.size() % 2 == 0) {
    decision.median_difference =
        0.5 * (decision.median_difference +
               *std::max_element(differences.begin(), differences.begin() + half));
  }
  if (decision.median_difference != 0.0) {
    decision.hand = decision.median_difference > 0.0 ? Handedness::kRight : Handedness::kLeft;
  }
  decision.close = std::abs(decision.median_difference) < handedness.close_margin;
  return decision;
}

std::string handednessText(const HandednessDecision& decision) {
  const bool right = decision.hand == Handedness::kRight;
  if (!decision.decided) {
    return std::string(right ? "right" : "left") +
           " (the model's own: no set where both hands had a pose)";
  }
  const int higher = right ? decision.right_higher : decision.sets - decision.right_higher;
  return std::string(right ? "right" : "left") + " (higher than a " + (right ? "left" : "right") +
         " hand in " + std::to_string(higher) + " of " + std::to_string(decision.sets) +
         " sets, by " + fixedNumber(std::abs(decision.median_difference), 4) +
         " in the median; mean energy " +
         fixedNumber(right ? decision.right_energy : decision.left_energy, 3) + " against " +
         fixedNumber(right ? decision.left_energy : decision.right_energy, 3) +
         (decision.close ? "; close: give --hand if you know" : "") + ")";
}

}  // namespace sag_hand_tracker
