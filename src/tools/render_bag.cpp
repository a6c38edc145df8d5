// render_bag: renders a sequence of the synthetic studio into a bag in the interface that track_bag
// reads (/cam<i>/image_raw rgb8, /cam<i>/camera_info, /tf_static root -> cam<i>_optical_frame,
// identical stamps per set), with the ground truth in the bag (/ground_truth/joint_states,
// /ground_truth/fingertips) and in a CSV with track_bag's columns. No ROS master needed.
//
//   rosrun sag_hand_tracker render_bag --sequence <name|motion.yaml> --rig <name|dir|rig.yaml>
//       --out OUT.bag [--fps 25|60] [--frames N] [--seed S] [--gt-csv FILE] [more, see --help]
//
// Exit status: 0 done; 1 bad input (one-line message on stderr); 2 bad command line; 130
// interrupted (Ctrl-C, SIGTERM: nothing written, the temporary files removed).
// The work is renderStudioBag (sag_ros), which the benchmark calls as well.
#include <atomic>
#include <csignal>
#include <iostream>
#include <string>
#include <vector>

#include "sag_hand_tracker/apps/progress.h"
#include "sag_hand_tracker/apps/render_runner.h"
#include "sag_hand_tracker/util/types.h"

namespace {

std::atomic<bool> g_stop{false};

// Stops between two frames, so that the outputs' temporary files are removed on the way out.
void onSignal(int) { g_stop = true; }

}  // namespace

int main(int argc, char** argv) {
  using namespace sag_hand_tracker;
  RenderBagOptions options;
  try {
    options = parseRenderBagArguments(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const UsageError& error) {
    std::cerr << "render_bag: " << error.what() << "\n" << renderBagUsage();
    return 2;
  }
  if (options.help) {
    std::cout << renderBagUsage();
    return 0;
  }
  try {
    std::signal(SIGINT, onSignal);
    std::signal(SIGTERM, onSignal);
    ProgressBar progress(std::cerr, stderrIsTerminal());
    const RenderBagSummary summary =
        renderStudioBag(options, options.quiet ? nullptr : &progress, &g_stop);
    std::cerr << formatRenderBagSummary(summary);
    return 0;
  } catch (const Interrupted& interrupted) {
    std::cerr << "\nrender_bag: " << interrupted.what() << "\n";
    return 130;
  } catch (const std::exception& error) {
    std::cerr << "render_bag: error: " << error.what() << "\n";
  }
  return 1;
}
