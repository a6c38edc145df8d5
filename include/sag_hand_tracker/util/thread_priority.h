// Thread priority for background work that must not delay the frame path (issue 12).
#pragma once

namespace sag_hand_tracker {

// Raises the calling thread's nice value by `increment` (a lower scheduling priority, so that the
// threads of the frame path, at the process' priority, take the CPU first when both want it).
// Needs no privilege. Returns false when it could not be changed (not Linux, or the call failed);
// increment <= 0 changes nothing and returns true.
bool lowerCurrentThreadPriority(int increment);

// The calling thread's nice value (Linux; 0 elsewhere).
int currentThreadNiceness();

}  // namespace sag_hand_tracker
