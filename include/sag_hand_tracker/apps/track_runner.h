// The offline tracking loop of track_bag (and of anything else that tracks a bag the same way):
// command line, reading sets from a bag, the per-set tracking call, the CSV, the progress bar and
// the summary. The tracking itself is passed in to runTrackBag, so the loop is tested without it;
// trackBag is the whole tool (model, bag reader, TrackingPipeline, loop, CSV), which track_bag's
// main and the benchmark both call, so they run the same code.
#pragma once

#include <atomic>
#include <functional>
#include <optional>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "sag_hand_tracker/apps/command_line.h"
#include "sag_hand_tracker/apps/csv.h"
#include "sag_hand_tracker/apps/progress.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/optimization/optimizer.h"
#include "sag_hand_tracker/ros/bag_input.h"
#include "sag_hand_tracker/tracking/frame_set.h"
#include "sag_hand_tracker/tracking/tracking_pipeline.h"

namespace sag_hand_tracker {

struct TrackBagOptions {
  std::string bag;                                // --bag (required)
  std::string out;                                // --out (required)
  std::string model = "sag";                      // --model sag|sog|FILE
  int iterations = OptimizerParams().iterations;  // --iterations N (>= 1)
  std::string step_control = "rprop";             // --step-control rprop|fixed
  std::vector<int> cameras;                       // --cameras 0,2,4 (empty: all)
  int background_frames = 10;                     // --background-frames N (>= 0)
  // --background-frames was given. Without it, a bag with no more images per camera than the
  // default background frames (a pair of photographs) is tracked without a plate (as with 0),
  // since a plate would take every frame.
  bool background_frames_given = false;
  Handedness hand = Handedness::kRight;  // --hand left|right
  // --hand auto: the first second with the hand is tracked as a right and as a left hand, and the
  // one the images prefer is kept (decideHandedness); then the bag is tracked from its start.
  bool hand_auto = false;
  // --room-cues / --no-room-cues: SegmentationParams::room.enabled (doc/segmentation.md). Unset:
  // on exactly when there is no plate (background_frames 0): the skin gate alone keeps every
  // skin-coloured thing of a room (a face: 24-28 % of a real office image's pixels).
  std::optional<bool> room_cues;
  // --fixed-colours: TrackerParams::colour_adaptation off (the model's colours as loaded)
  bool fixed_colours = false;
  // --generic-skin-gate: the skin gate of SegmentationParams::skin even with a model whose colours
  // are the user's (PipelineParams::skin_gate_from_model off)
  bool generic_skin_gate = false;
  std::string root_frame;  // --root-frame FRAME (empty: the root of the bag's tf tree)
  double stamp_tolerance = BagReaderOptions().stamp_tolerance;  // --stamp-tolerance S
  // --overlay-dir DIR: a picture of the tracked model over the images (tracking_overlay.h) for
  // every overlay_every-th set after the background (--overlay-every N), each start and the first
  // frame of each lost stretch. Empty: none.
  std::string overlay_dir;
  int overlay_every = 25;
  bool overwrite = false;  // --overwrite: replace a file at --out (default: refused)
  bool quiet = false;      // --quiet: no progress bar
  bool help = false;       // --help
  // Where the built-in models ("sag", "sog") are; empty: the package's config/ (found through
  // ROS_PACKAGE_PATH). Not a command-line option of track_bag; the benchmark sets it.
  std::string config_dir;
};

// Parses the arguments after the program name. Throws UsageError.
TrackBagOptions parseTrackBagArguments(const std::vector<std::string>& args);
std::string trackBagUsage();

// What happened over a run.
struct TrackBagSummary {
  std::string bag;
  std::string csv;
  std::vector<std::string> cameras;   // names of the cameras read
  int frames = 0;                     // sets processed
  int background_frames = 0;          // sets learned as background
  int tracked_frames = 0;             // sets with an accepted pose (status started or tracked)
  int waiting_frames = 0;             // sets after the background without a pose
  int lost_frames = 0;                // status lost (not tracked)
  int lost_rows = 0;                  // lost with a pose: a CSV row with status "lost"
  int restarted_frames = 0;           // the track was started again after being lost
  int incomplete_sets = 0;            // sets where a camera was missing
  int dropped_images = 0;             // late or duplicate images (see BagReaderStatistics)
  long image_gaussians = 0;           // foreground image Gaussians over the tracked sets
  double decode_seconds = 0.0;        // reading and decoding the bag (excluded from fps)
  double background_seconds = 0.0;    // learning the background plates
  double segmentation_seconds = 0.0;  // segmentation of the tracked sets
  double tracking_seconds = 0.0;      // HandTracker::update of the tracked sets
  double pipeline_seconds = 0.0;      // the whole tracking call over the sets after the background
  bool interrupted = false;
  bool csv_written = false;  // trackBag: the CSV was renamed into place
  bool out_existed = false;  // trackBag: a file was at --out before the run
  // The reader's statistics at the end: its stamp checks (stampWarnings, stampFailure; the same
  // words as calibrate_hand's) and the stamps it joined within the tolerance.
  BagReaderStatistics reading;
  // Without a plate: which skin gate segmented the images ("generic", or the user's from the
  // model's colours with its ranges); empty with a plate.
  std::string skin_gate;
  // The model's size at the end against the one it started with (TrackerParams::size_step).
  double model_size = 1.0;
  int overlays_written = 0;  // --overlay-dir: the pictures written there
  std::string overlay_dir;
  // With --hand auto: the hand chosen and why (handednessText); empty otherwise.
  std::string handedness;
  // Why the run's background frames are not the option's (a bag too short for a plate); empty
  // otherwise.
  std::string background_note;

  // Frames per second of the pipeline (segmentation + optimisation, decode excluded) over the
  // sets after the background phase; 0 when there were none.
  double pipelineFps() const;
};

// One-paragraph summary for the end of a run.
std::string formatSummary(const TrackBagSummary& summary);

// Whether trackBag renames its CSV into place: a finished run when it tracked a frame; an
// interrupted one when it wrote rows and nothing was at --out before (the partial rows of an
// interrupted run never replace an earlier output).
bool commitsTrackCsv(const TrackBagSummary& summary, std::size_t rows);

// The per-set tracking call.
using TrackFrameFunction = std::function<ProcessedFrame(const FrameSet&)>;
// What a run does with each set and its result besides the CSV (the overlays), outside the timing.
using TrackedFrameObserver = std::function<void(const FrameSet&, const ProcessedFrame&)>;

// Reads every set of `reader`, calls `track` on it (timed), writes a CSV row for each result
// with a pose, calls `observe` (may be empty; not timed) and updates `progress` (may be null).
// Stops early, with summary.interrupted set, when `stop` (may be null) becomes true. InputError
// from the reader, `track` or `observe` propagates.
TrackBagSummary runTrackBag(BagReader& reader, const TrackFrameFunction& track,
                            TrackingCsvWriter& csv, ProgressBar* progress,
                            const std::atomic<bool>* stop = nullptr,
                            const TrackedFrameObserver& observe = nullptr);

// The CSV row of a result with a pose, with its status column.
TrackingCsvRow toCsvRow(const FrameResult& result);
// The status column's word: "started", "tracked", "lost" ("waiting" has no row).
std::string csvStatus(TrackStatus status);

// The file of a model given as "sag", "sog" (built-in, in `config_dir`, or the package's config/
// when empty) or a path. Throws InputError if the package is needed and cannot be found.
std::string trackBagModelPath(const std::string& name_or_path, const std::string& config_dir);

// The pipeline parameters that the options set (iterations, step control, background frames).
PipelineParams trackBagPipelineParams(const TrackBagOptions& options);

// The whole of track_bag: loads the model, opens the bag (options.cameras, options.root_frame),
// builds the TrackingPipeline and runs runTrackBag into the CSV options.out. `progress` and
// `stop` may be null. --out equal to an input is refused before anything is opened; the CSV is
// written to a temporary file and moved to options.out only when a frame was tracked
// (summary.csv_written, commitsTrackCsv; without options.overwrite the move replaces nothing, not
// even a file created there during the run: InputError naming where the CSV was kept), so a failure
// (rethrown), a run without a tracked frame or an interrupted run leaves whatever was at
// options.out untouched. The caller decides what no tracked frame means.
TrackBagSummary trackBag(const TrackBagOptions& options, ProgressBar* progress,
                         const std::atomic<bool>* stop = nullptr);

}  // namespace sag_hand_tracker
