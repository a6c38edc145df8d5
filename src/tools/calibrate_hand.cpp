// calibrate_hand: fits the hand model to the user's hand from a recording of the calibration
// routine, offline, without a ROS master, and writes the fitted model YAML (see --help and
// doc/calibration.md).
//
//   rosrun sag_hand_tracker calibrate_hand --bag IN.bag --out my_hand.yaml [--model START]
//       [--hand left|right] [--background-frames N] [--contact-sheet PNG]
//
// Exit status: 0 done; 1 bad input or a recording that does not show the routine (message on
// stderr, no file written); 2 bad command line.
#include <atomic>
#include <csignal>
#include <iostream>
#include <string>
#include <vector>

#include "sag_hand_tracker/apps/progress.h"
#include "sag_hand_tracker/apps/calibrate_runner.h"
#include "sag_hand_tracker/util/types.h"

namespace {
std::atomic<bool> g_stop{false};
void onSignal(int) { g_stop = true; }
}  // namespace

int main(int argc, char** argv) {
  using namespace sag_hand_tracker;
  CalibrateHandOptions options;
  try {
    options = parseCalibrateHandArguments(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const UsageError& error) {
    std::cerr << "calibrate_hand: " << error.what()
              << "\nRun 'calibrate_hand --help' for the options.\n";
    return 2;
  }
  if (options.help) {
    std::cout << calibrateHandUsage();
    return 0;
  }
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
  try {
    ProgressBar progress(std::cerr, stderrIsTerminal());
    const CalibrateHandSummary summary =
        calibrateHand(options, options.quiet ? nullptr : &progress, &g_stop);
    std::cout << formatCalibrateHandSummary(summary) << std::flush;
    return 0;
  } catch (const InputError& error) {
    std::cerr << "calibrate_hand: error: " << error.what() << "\n";
    return 1;
  } catch (const std::exception& error) {
    std::cerr << "calibrate_hand: internal error: " << error.what() << "\n";
    return 1;
  }
}
