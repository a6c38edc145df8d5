// The body of the calibrate_hand tool as a library function: reads a bag of the calibration
// routine, tracks it with the start model (TrackingPipeline, as track_bag), checks that the
// routine was followed, fits the model to the hand (hand_fit.h) and writes the fitted model YAML
// (through a temporary file renamed at the end; nothing is written on failure), and optionally a
// contact sheet of the fitted model over the images. No ROS master needed.
#pragma once

#include <atomic>
#include <string>
#include <vector>

#include "sag_hand_tracker/apps/command_line.h"
#include "sag_hand_tracker/apps/progress.h"
#include "sag_hand_tracker/fitting/hand_fit.h"

namespace sag_hand_tracker {

struct CalibrateHandOptions {
  std::string bag;                       // --bag (required)
  std::string out;                       // --out (required; must not exist)
  std::string model = "sag";             // --model sag|FILE: the start model
  Handedness hand = Handedness::kRight;  // --hand left|right
  int background_frames = 10;            // --background-frames N
  std::string contact_sheet;             // --contact-sheet PNG (must not exist)
  int max_frames = 16;                   // --max-frames N: frames used by the fit
  int rounds = 2;                        // --rounds N: sweeps of the greedy search
  bool require_routine = false;          // --require-routine: refuse an incomplete routine
  // --truth-shape NAME|FILE: a studio hand (config/hand_shapes.yaml) whose true skeleton the
  // summary compares the fitted one with (the bag must show that hand; empty: no comparison)
  std::string truth_shape;
  // --truth-model sag|FILE: the skeleton render_bag shaped that hand from (its --model), not the
  // start model: a start that is itself a fitted model would make the truth wrong
  std::string truth_model = "sag";
  bool quiet = false;
  bool help = false;
  std::string config_dir;  // where "sag" is (empty: the package's config/); tests set it
};

CalibrateHandOptions parseCalibrateHandArguments(const std::vector<std::string>& args);
std::string calibrateHandUsage();

struct CalibrateHandSummary {
  std::string bag;
  std::string out;
  std::string contact_sheet;  // empty: none written
  int frames = 0;             // sets read
  int tracked_frames = 0;     // with a pose
  int cameras = 0;
  RoutineCheck routine;
  HandFitResult fit;
  HandModel start_model;
  // The size the routine's tracker ended with (TrackerParams::size_step): the fit starts from
  // start_model scaled by it (scaleHandModel), and fit.shape's factors are on top of it.
  double start_size = 1.0;
  double tips_on_foreground_before = 0.0;  // fingertip reprojection check, fraction
  double tips_on_foreground_after = 0.0;
  double seconds = 0.0;
  std::string truth_shape;  // --truth-shape, empty: none
  SkeletonErrors truth_errors;
  // The bag reader's stamp problems (stampWarnings: the words of track_bag's summary).
  std::vector<std::string> stamp_warnings;
};

// The whole tool. Throws InputError with a message naming the problem (bad bag, fewer than two
// cameras, too little of the hand to fit and what is missing, with --require-routine any pose of
// the routine missing, an existing output file); on any error
// neither the model nor the contact sheet is left behind. `stop` may be null.
CalibrateHandSummary calibrateHand(const CalibrateHandOptions& options, ProgressBar* progress,
                                   const std::atomic<bool>* stop = nullptr);

// The closing report: fitted parameters, energy and shape score before and after, the fingertip
// reprojection check, the output files.
std::string formatCalibrateHandSummary(const CalibrateHandSummary& summary);

}  // namespace sag_hand_tracker
