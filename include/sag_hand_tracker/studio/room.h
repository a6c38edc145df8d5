// Studio rooms: the clean studio plus what a real room puts in front of the cameras (issue 11) —
// a face at the edge of some views, skin-coloured and wooden objects, a second (resting) arm,
// photographs on the walls and the table, light that changes during the sequence, and sequences
// that never show the scene without the hand. Everything that is not the tracked hand carries
// the label kLabelProp, so that foreground precision can be measured against the label image.
#pragma once

#include <string>
#include <vector>

#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/studio/hand_surface.h"
#include "sag_hand_tracker/studio/renderer.h"

namespace sag_hand_tracker {
namespace studio {

// Label of every prop (face, objects, the other arm). isSkinLabel() is true for it (it is >=
// kLabelForearm); use isTrackedHandLabel for "belongs to the tracked hand".
constexpr std::uint8_t kLabelProp = 64;
// Palm, fingers and the bare wrist of the tracked hand (not its sleeve, not the props).
inline bool isTrackedHandLabel(std::uint8_t label) {
  return label >= kLabelForearm && label < kLabelProp;
}

struct RoomParams {
  std::string name;
  // Photographs (files under config/studio/, see its README for their licences); empty: none.
  std::string table_photo;
  std::string wall_photo;
  bool face = false;          // a face-like skin blob behind the workspace, at the edge of views
  bool second_arm = false;    // the other arm, sleeved, its hand resting on the table, drifting
  bool skin_objects = false;  // a pink ball and a cardboard box
  bool wood_objects = false;  // a wooden block and a wooden rod
  // The light's gain is 1 - light_change * (1 - cos(2 pi t / light_period)) / 2: daylight that
  // dims by up to light_change and comes back.
  double light_change = 0.0;
  double light_period = 8.0;  // seconds
  // Whether the sequence starts with frames without the hand (SequenceParams::empty_frames); a
  // room without them can only be tracked with the skin gate.
  bool hand_free_frames = true;
};

// "office", "kitchen", "daylight" (see studio_room.cpp and doc/segmentation.md).
const std::vector<std::string>& builtinRoomNames();
// Throws InputError for an unknown name.
RoomParams builtinRoom(const std::string& name);

class StudioRoom {
 public:
  // `model`: the (shaped) hand model whose skeleton poses the second arm. Loads the photographs
  // from `config_dir`/studio/; throws InputError naming a missing or unreadable photograph.
  StudioRoom(const RoomParams& params, const HandModel& model, const std::string& config_dir);

  const RoomParams& params() const { return params_; }
  // The scene with the room's photographs.
  StudioSceneParams scene(StudioSceneParams base = StudioSceneParams()) const;
  // The props at time t (seconds), labelled kLabelProp.
  std::vector<SurfacePart> props(double time) const;
  // Adds the props at `time` to every sub-frame (and makes one sub-frame when there is none).
  void addProps(std::vector<std::vector<SurfacePart>>* subframes, double time) const;
  double lightGain(double time) const;

 private:
  RoomParams params_;
  HandModel model_;
  cv::Mat table_photo_;
  cv::Mat wall_photo_;
};

}  // namespace studio
}  // namespace sag_hand_tracker
