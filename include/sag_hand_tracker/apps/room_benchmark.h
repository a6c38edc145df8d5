// benchmark --rooms (issue 11): the studio rooms (studio/room.h) against the clean studio, with
// the skin gate and with the plate, each without and with the room cues (RoomCueParams):
// foreground precision / recall against the studio's label images and fingertip error, on each
// of the benchmark's hands.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "sag_hand_tracker/apps/evaluation.h"
#include "sag_hand_tracker/studio/hand_shapes.h"

namespace sag_hand_tracker {

// A hand rendered in the rooms and, when not empty, the model fitted to it in the clean studio
// (--fitted: the calibration routine rendered on that hand, a user who ran calibrate_hand once).
struct RoomHand {
  studio::StudioHand hand;
  std::string fitted_model;
};

// Renders and tracks in memory (no bags); writes DIR/rooms.md, DIR/rooms.csv and, per sequence,
// hand and room, the before/after foreground masks of one frame (DIR/rooms/*.png). Returns the
// Markdown report. Throws InputError for an unknown room or sequence.
// Each hand is tracked with the --models and, when it has a fitted model, with that model twice:
// with the skin gate of its colours ("SAG fitted", PipelineParams::skin_gate_from_model) and with
// the generic one ("SAG fitted (generic gate)").
std::string runRoomBenchmark(const BenchmarkOptions& options, const std::vector<RoomHand>& hands,
                             std::ostream& log);

}  // namespace sag_hand_tracker
