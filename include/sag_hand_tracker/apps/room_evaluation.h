// Evaluation of the segmentation and the tracker in the studio rooms (issue 11): renders a
// sequence in a room (or the clean studio), runs TrackingPipeline for several configurations on
// the same images, and measures foreground precision / recall against the label image and the
// fingertip error against the ground truth. In memory, no bags. Core library, no ROS.
#pragma once

#include <string>
#include <vector>

#include "sag_hand_tracker/apps/metrics.h"
#include "sag_hand_tracker/studio/hand_shapes.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/studio/room.h"
#include "sag_hand_tracker/tracking/tracking_pipeline.h"

namespace sag_hand_tracker {
namespace studio {

struct RoomRunConfig {
  std::string label;  // e.g. "SAG skin + cues"
  HandModel model;    // the tracker's model
  PipelineParams pipeline;
};

struct RoomRunResult {
  std::string label;
  int frames = 0;        // frames with the hand that were tracked (not background)
  int frames_posed = 0;  // of those, frames where the tracker had a pose (not waiting/lost)
  // Frames without the hand that were tracked (not background), and those with a pose: a hand
  // reported where there is none (a face, a photograph, the other arm).
  int empty_frames = 0;
  int empty_frames_posed = 0;
  std::vector<double> errors_mm;  // per posed frame, mean fingertip error
  ErrorSummary errors;
  // Foreground pixels over all cameras and tracked frames: kept (mask), kept that are the
  // tracked hand (isTrackedHandLabel), and hand pixels in the label images.
  long long kept = 0;
  long long kept_hand = 0;
  long long hand = 0;
  double precision() const { return kept > 0 ? static_cast<double>(kept_hand) / kept : 0.0; }
  double recall() const { return hand > 0 ? static_cast<double>(kept_hand) / hand : 0.0; }
};

struct RoomSequenceOptions {
  int frames = 0;         // 0: the motion's length
  int empty_frames = 10;  // frames without the hand at the start (0 for rooms without them)
  std::uint64_t seed = 1;
  StudioHand hand;  // the rendered hand's proportions and skin (config/hand_shapes.yaml)
  // When not empty: writes <dump_prefix>_image.png (camera dump_camera's image of frame
  // dump_frame) and <dump_prefix>_<k>.png (configuration k's foreground mask over it).
  std::string dump_prefix;
  int dump_frame = -1;
  int dump_camera = 0;
};

// `room`: nullptr for the clean studio. `config_dir` holds studio/ (the photographs).
std::vector<RoomRunResult> evaluateRoomSequence(const HandModel& render_model,
                                                const std::vector<Camera>& cameras,
                                                const Motion& motion, const RoomParams* room,
                                                const std::string& config_dir,
                                                const std::vector<RoomRunConfig>& configs,
                                                const RoomSequenceOptions& options);

}  // namespace studio
}  // namespace sag_hand_tracker
