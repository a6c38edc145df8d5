#include "sag_hand_tracker/studio/sequence.h"

#include <cmath>

#include "sag_hand_tracker/kinematics.h"
#include "sag_hand_tracker/studio/renderer.h"
#include "sag_hand_tracker/types.h"

namespace sag_hand_tracker {
namespace studio {

StudioSequence::StudioSequence(const HandModel& model, Motion motion, const SequenceParams& params)
    : shaped_(shapeHandModel(model, params.shape)), motion_(std::move(motion)), params_(params) {
  if (!(params_.fps > 0.0) || !std::isfinite(params_.fps)) {
    throw InputError("studio sequence: fps must be positive");
  }
  if (params_.frames < 0) throw InputError("studio sequence: frames must not be negative");
  if (params_.empty_frames < 0) {
    throw InputError("studio sequence: empty_frames must not be negative");
  }
  if (params_.motion_blur_samples < 1) {
    throw InputError("studio sequence: motion_blur_samples must be at least 1");
  }
  if (params_.exposure < 0.0 || params_.exposure > 1.0 / params_.fps) {
    throw InputError("studio sequence: the exposure must lie within one frame period");
  }
  frames_ = params_.frames > 0 ? params_.frames
                               : static_cast<int>(std::lround(motion_.duration * params_.fps));
}

StudioFrame StudioSequence::frame(int index) const {
  StudioFrame f;
  f.index = index;
  f.time = frameTime(index);
  f.hand_present = index >= params_.empty_frames;
  f.pose = motion_.poseAt(f.time);
  const PosedHand posed = forwardKinematics(shaped_, f.pose);
  f.fingertips = boneFingertips(shaped_, posed.bone_frames);
  return f;
}

std::vector<std::vector<SurfacePart>> StudioSequence::surfaces(int index) const {
  std::vector<std::vector<SurfacePart>> out;
  if (index < params_.empty_frames) return out;
  const int n = params_.motion_blur_samples;
  for (int s = 0; s < n; ++s) {
    const double offset = n == 1 ? 0.0 : params_.exposure * (s / (n - 1.0) - 0.5);
    const Pose pose = motion_.poseAt(frameTime(index) + offset);
    const PosedHand posed = forwardKinematics(shaped_, pose);
    out.push_back(buildHandSurface(shaped_, posed.bone_frames, params_.surface, params_.shape));
  }
  return out;
}

std::uint64_t StudioSequence::noiseSeed(int index) const {
  return mixSeed(params_.seed, static_cast<std::uint64_t>(index));
}

}  // namespace studio
}  // namespace sag_hand_tracker
