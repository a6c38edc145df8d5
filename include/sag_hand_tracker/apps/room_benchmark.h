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
std::string runRoomBenchmark(const BenchmarkOptions& options, std::ostream& log);

}  // namespace sag_hand_tracker
