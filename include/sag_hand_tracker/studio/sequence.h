// A studio sequence: a motion played on a shaped hand at a frame rate, with the empty studio for
// the first frames, per-frame ground truth (pose, fingertips) and the surfaces to render (one per
// sub-frame for motion blur). Deterministic: everything follows from the motion and the seed.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/pose.h"
#include "sag_hand_tracker/studio/hand_surface.h"
#include "sag_hand_tracker/studio/motion.h"

namespace sag_hand_tracker {
namespace studio {

struct SequenceParams {
  double fps = 25.0;      // Dexter 1's rate; 60 is the other common one
  int frames = 0;         // 0: the motion's duration * fps (rounded)
  int empty_frames = 10;  // frames 0..empty_frames-1 show the studio without the hand
  HandShape shape;        // size and proportions of the rendered hand
  HandSurfaceParams surface;
  int motion_blur_samples = 1;  // sub-frames averaged per frame; 1 = no motion blur
  double exposure = 0.010;      // seconds, centred on the frame time (used with motion blur)
  std::uint64_t seed = 1;       // sensor noise (the motion's randomness is drawn at its loading)
};

struct StudioFrame {
  int index = 0;
  double time = 0.0;  // seconds from the first frame
  bool hand_present = false;
  Pose pose;              // meaningful when the hand is present
  Fingertips fingertips;  // of the rendered (shaped) hand
};

class StudioSequence {
 public:
  // `model` is the hand model (unshaped); the sequence renders and measures its shaped copy.
  // Throws InputError for bad parameters.
  StudioSequence(const HandModel& model, Motion motion, const SequenceParams& params);

  int frameCount() const { return frames_; }
  double frameTime(int index) const { return index / params_.fps; }
  StudioFrame frame(int index) const;
  // The hand surface at each sub-frame of frame `index` (empty when the hand is absent).
  std::vector<std::vector<SurfacePart>> surfaces(int index) const;
  // The seed of frame `index`'s sensor noise.
  std::uint64_t noiseSeed(int index) const;

  const HandModel& shapedModel() const { return shaped_; }
  const Motion& motion() const { return motion_; }
  const SequenceParams& params() const { return params_; }

 private:
  HandModel shaped_;
  Motion motion_;
  SequenceParams params_;
  int frames_ = 0;
};

// A camera rig file: a directory holding rig.yaml, a rig file, or the name of a built-in rig
// (`<config_dir>/rigs/<name>/rig.yaml`, e.g. "dexter5"). Throws InputError when none exists.
std::string resolveRigPath(const std::string& name_or_path, const std::string& config_dir);

}  // namespace studio
}  // namespace sag_hand_tracker
