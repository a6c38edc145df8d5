// benchmark --rooms (issue 11): the studio rooms (studio/room.h) against the clean studio, with
// the skin gate and with the plate, each without and with the room cues (RoomCueParams):
// foreground precision / recall against the studio's label images and fingertip error.
#pragma once

#include <ostream>
#include <string>

#include "sag_hand_tracker/apps/evaluation.h"

namespace sag_hand_tracker {

// Renders and tracks in memory (no bags); writes DIR/rooms.md, DIR/rooms.csv and, per sequence
// and room, the before/after foreground masks of one frame (DIR/rooms/*.png). Returns the
// Markdown report. Throws InputError for an unknown room or sequence.
// `fitted_model` (--fitted: the model fitted to the calibration routine rendered on the default
// hand in the clean studio, a user who ran calibrate_hand; empty: none) is tracked beside the
// --models twice: with the skin gate of its colours ("SAG fitted", PipelineParams::
// skin_gate_from_model) and with the generic one ("SAG fitted (generic gate)").
std::string runRoomBenchmark(const BenchmarkOptions& options, std::ostream& log,
                             const std::string& fitted_model = "");

}  // namespace sag_hand_tracker
