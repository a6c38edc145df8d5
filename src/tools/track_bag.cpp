// track_bag: tracks the hand in a bag of calibrated cameras, offline, without a ROS master, and
// writes the fingertips and pose parameters per frame to a CSV (see --help).
//
//   rosrun sag_hand_tracker track_bag --bag IN.bag --out OUT.csv [--model sag|sog|FILE]
//       [--iterations N] [--cameras 0,2,4] [--background-frames N] [--hand left|right]
//
// Exit status: 0 done; 1 bad input (one-line message on stderr) or no frame tracked (then no
// CSV); 2 bad command line; 130 interrupted (the rows so far are in the CSV, unless a file was at
// --out before: that one is left as it was).
#include <atomic>
#include <csignal>
#include <iostream>
#include <string>
#include <vector>

#include "sag_hand_tracker/apps/progress.h"
#include "sag_hand_tracker/apps/track_runner.h"
#include "sag_hand_tracker/util/types.h"

// The work is trackBag (sag_ros: model, bag reader, TrackingPipeline, the loop, the CSV), which
// the benchmark calls as well, so both measure the same tracker.
namespace sag_hand_tracker {
namespace {

std::atomic<bool> g_stop{false};

void onSignal(int) { g_stop = true; }

int run(const TrackBagOptions& options) {
  ProgressBar progress(std::cerr, stderrIsTerminal());
  const TrackBagSummary summary = trackBag(options, options.quiet ? nullptr : &progress, &g_stop);
  std::cout << formatSummary(summary) << std::flush;

  if (summary.interrupted) return 130;
  if (summary.tracked_frames == 0) {
    std::cerr << "track_bag: error: no frame was tracked: ";
    // Not "the hand was not found" when the stamps explain it (calibrate_hand says the same).
    const std::string stamps = stampFailure(summary.reading, summary.frames, "--stamp-tolerance");
    if (!stamps.empty()) {
      std::cerr << stamps;
    } else if (summary.frames == summary.background_frames) {
      // Not "not found in the 0 frames after the N background frames": the bag is that short.
      std::cerr << "the bag has " << summary.frames << " frame" << (summary.frames == 1 ? "" : "s")
                << ", all taken as background frames (--background-frames "
                << options.background_frames
                << "): none could show the hand (a recording with the hand in view from its first "
                   "frame needs --background-frames 0)";
    } else {
      std::cerr << "the hand was not found in the " << summary.frames - summary.background_frames
                << " frames after the " << summary.background_frames << " background frames";
      if (summary.lost_frames > 0) {
        std::cerr << " (" << summary.lost_frames << " poses were rejected as lost)";
      }
    }
    std::cerr << "; " << options.out
              << (summary.csv_written ? " holds only lost rows" : " was not written") << "\n";
    return 1;
  }
  return 0;
}

}  // namespace
}  // namespace sag_hand_tracker

int main(int argc, char** argv) {
  using namespace sag_hand_tracker;
  TrackBagOptions options;
  try {
    options = parseTrackBagArguments(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const UsageError& error) {
    std::cerr << "track_bag: " << error.what() << "\nRun 'track_bag --help' for the options.\n";
    return 2;
  }
  if (options.help) {
    std::cout << trackBagUsage();
    return 0;
  }
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  try {
    return run(options);
  } catch (const InputError& error) {
    std::cerr << "track_bag: error: " << error.what() << "\n";
    return 1;
  } catch (const std::exception& error) {
    std::cerr << "track_bag: internal error: " << error.what() << "\n";
    return 1;
  }
}
