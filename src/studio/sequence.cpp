#include "sag_hand_tracker/studio/sequence.h"

#include <cmath>
#include <filesystem>

#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/studio/renderer.h"
#include "sag_hand_tracker/util/types.h"

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
  // A motion made for a bare forearm keeps it; the caller can make any motion bare.
  if (motion_.bare_forearm.value_or(false)) params_.surface.bare_forearm = true;
  if (motion_.forearm_bend) params_.surface.forearm_bend = *motion_.forearm_bend;
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

std::string resolveRigPath(const std::string& name_or_path, const std::string& config_dir) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (fs::is_directory(name_or_path, error)) {
    const fs::path rig = fs::path(name_or_path) / "rig.yaml";
    if (fs::is_regular_file(rig, error)) return rig.string();
    throw InputError("rig directory " + name_or_path + " holds no rig.yaml");
  }
  if (fs::is_regular_file(name_or_path, error)) return name_or_path;
  if (name_or_path.find('/') == std::string::npos) {
    const fs::path rig = fs::path(config_dir) / "rigs" / name_or_path / "rig.yaml";
    if (fs::is_regular_file(rig, error)) return rig.string();
  }
  throw InputError("no camera rig '" + name_or_path + "': give a built-in rig name (" +
                   (fs::path(config_dir) / "rigs").string() +
                   "/<name>), a directory with rig.yaml, or a rig file");
}

}  // namespace studio
}  // namespace sag_hand_tracker
