// track_bag: tracks the hand in a bag of calibrated cameras, offline, without a ROS master, and
// writes the fingertips and pose parameters per frame to a CSV (see --help).
//
//   rosrun sag_hand_tracker track_bag --bag IN.bag --out OUT.csv [--model sag|sog|FILE]
//       [--iterations N] [--cameras 0,2,4] [--background-frames N] [--hand left|right]
//
// Exit status: 0 done; 1 bad input (one-line message on stderr) or no frame tracked; 2 bad
// command line; 130 interrupted (the rows so far are in the CSV).
#include <ros/package.h>

#include <atomic>
#include <csignal>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "sag_hand_tracker/csv.h"
#include "sag_hand_tracker/hand_model.h"
#include "sag_hand_tracker/optimizer.h"
#include "sag_hand_tracker/progress.h"
#include "sag_hand_tracker/ros/bag_input.h"
#include "sag_hand_tracker/ros/track_bag_runner.h"
#include "sag_hand_tracker/tracking_pipeline.h"
#include "sag_hand_tracker/types.h"

namespace sag_hand_tracker {
namespace {

std::atomic<bool> g_stop{false};

void onSignal(int) { g_stop = true; }

// The built-in models ("sag", "sog") live in the package's config folder.
std::string modelPath(const std::string& name_or_path) {
  if (name_or_path != "sag" && name_or_path != "sog") return name_or_path;
  const std::string package = ros::package::getPath("sag_hand_tracker");
  if (package.empty()) {
    throw InputError("cannot find the package sag_hand_tracker for the built-in model '" +
                     name_or_path + "': source devel/setup.bash, or pass --model FILE");
  }
  return resolveModelPath(name_or_path, package + "/config");
}

PipelineParams pipelineParams(const TrackBagOptions& options) {
  PipelineParams params;
  params.tracker.optimizer.iterations = options.iterations;
  params.tracker.optimizer.step_control = parseStepControl(options.step_control);
  params.background_frames = options.background_frames;
  return params;
}

// =================================================================================================
// THE TRACKING CALL. One synchronized set of camera images in, one result out: the first
// --background-frames sets train each camera's background plate; every later set is segmented
// per camera (image -> foreground image SoG, undistorted) and handed to HandTracker::update
// (automatic start, warm-started optimisation, restart when lost). Everything else in this tool
// is input and output. TrackingPipeline (core) is the same code the benchmark runs.
// =================================================================================================
ProcessedFrame trackFrameSet(TrackingPipeline& pipeline, const FrameSet& set) {
  return pipeline.process(set);
}

int run(const TrackBagOptions& options) {
  const HandModel model = loadHandModel(modelPath(options.model), options.hand);

  BagReaderOptions reader_options;
  reader_options.cameras = options.cameras;
  reader_options.root_frame = options.root_frame;
  BagReader reader(options.bag, reader_options);

  TrackingPipeline pipeline(model, reader.cameras(), pipelineParams(options));

  TrackBagSummary summary;
  try {
    TrackingCsvWriter csv(options.out, model.parameterNames());
    ProgressBar progress(std::cerr, stderrIsTerminal());
    summary = runTrackBag(
        reader, [&pipeline](const FrameSet& set) { return trackFrameSet(pipeline, set); }, csv,
        options.quiet ? nullptr : &progress, &g_stop);
  } catch (...) {
    // A run that failed half way leaves no CSV that could pass for a result.
    std::error_code ignored;
    std::filesystem::remove(options.out, ignored);
    throw;
  }
  std::cout << formatSummary(summary) << std::flush;

  if (summary.interrupted) return 130;
  if (summary.tracked_frames == 0) {
    std::cerr << "track_bag: error: no frame was tracked: the hand was not found in the "
              << summary.frames - summary.background_frames << " frames after the "
              << summary.background_frames << " background frames (" << options.out
              << " holds only the header)\n";
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
