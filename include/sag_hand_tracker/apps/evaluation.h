// The benchmark of issue 4 (the paper's section 5 on the synthetic studio): renders each sequence
// once with renderStudioBag (the code of render_bag), tracks it with every model through trackBag
// (the code of track_bag), matches the tracked rows to the ground truth by stamp, and reports the
// fingertip error (mean, sd, Table 1's percentages), the speed, and optionally the paper's
// Figure 6 (error against the number of cameras), as text, Markdown, CSV and PNG.
//
// Failures: a ground-truth frame without a tracked row (the tracker had no pose: waiting for the
// start or lost) is a failed frame. Its error is +inf: it counts against every bound of Table 1
// (percentages are over all ground-truth frames) and it is left out of the mean and sd, which are
// over the tracked frames; the number of failed frames is reported beside them.
//
// Hands and orientation (issue 9): every sequence is rendered on every hand shape asked for
// (config/hand_shapes.yaml; the tracker keeps its default model), and beside the fingertip error
// the benchmark reports the % of reversed frames (tracked wrist -> middle-knuckle direction more
// than 90 deg from the truth's), the % of rolled-over frames (back-of-hand normals, the palm
// frames' z axes, more than 90 deg apart) and the wrist (root position) error, from the 26 pose
// parameters of the tracked and the ground-truth rows (metrics.h, orientationError). These are
// over the tracked frames, like the mean.
//
// Fitted models (issue 10, --fitted): per hand shape the benchmark renders the calibration
// routine (config/motions/calibration_routine.yaml) on that hand, fits the default SAG model to it
// with calibrate_hand's code (calibrateHand, calibrate_runner.h), writes the model to
// DIR/models/<shape>.yaml and tracks every sequence of that hand with it as one more tracker,
// labelled "fitted", beside SAG with the default model. A fit that fails (a routine too short, not
// followed) is reported for its shape, and that shape has no fitted runs; the rest goes on.
#pragma once

#include <Eigen/Core>
#include <array>
#include <limits>
#include <ostream>
#include <string>
#include <vector>

#include "sag_hand_tracker/apps/calibrate_runner.h"
#include "sag_hand_tracker/apps/command_line.h"
#include "sag_hand_tracker/apps/track_runner.h"
#include "sag_hand_tracker/optimization/optimizer.h"

namespace sag_hand_tracker {

struct BenchmarkOptions {
  std::vector<std::string> sequences;  // --sequences a,b (default: benchmarkSequences())
  std::vector<std::string> shapes;     // --shapes a,b (empty: hand_shapes.yaml's; --rooms: default)
  int drawn_hands = 0;                 // --drawn-hands N: drawn1..drawnN added to `shapes`
  bool discard_bags = false;           // --discard-bags: remove rendered bags once tracked
  bool camera_counts = false;          // --camera-counts: the Figure 6 experiment
  int frames = 0;                      // --frames N rendered per sequence (0: full length)
  std::string out_dir = "benchmark";   // --out-dir DIR
  std::string csv;                     // --csv FILE (default DIR/results.csv)
  std::string rig = "dexter5";         // --rig name|dir|file
  int iterations = OptimizerParams().iterations;  // --iterations N (optimiser, per frame)
  std::vector<std::string> models{"sag", "sog"};  // --models sag,sog (or model files)
  bool rerender = false;   // --rerender (default --reuse: keep matching bags)
  std::string config_dir;  // --config-dir DIR (default: the package's config/)
  bool plots = true;       // --no-plots
  // --rooms office,kitchen,daylight|all: instead of the bags, the studio rooms against the clean
  // studio (room_benchmark.h), on each of --shapes; its default sequences are adbadd and pinch.
  std::vector<std::string> rooms;
  // --room-configs a,b: which of the room runs (skin, skin+cues, plate, plate+cues; default all).
  std::vector<std::string> room_configs{"skin", "skin+cues", "plate", "plate+cues"};
  // --fitted: per hand shape, fit the model to the calibration routine rendered on that hand and
  // track with it too (tracker "fitted"); needs "sag" among the models, the default it starts from.
  // With --rooms: each hand's fit in the clean studio, tracked in the rooms (runRoomBenchmark).
  bool fitted = false;
  int routine_frames = 0;  // --routine-frames N of the rendered routine (0: its full length)
  // --fit-sequence NAME: fit from this motion rendered on each hand (the first --routine-frames
  // of it) instead of the calibration routine: what a user gets from calibrate_hand on the first
  // seconds of any recording.
  std::string fit_sequence = "calibration_routine";
  bool help = false;
};

// A whole text output, written next to `path` and renamed there (atomic_output.h): the
// benchmark's own files, replaced each run, never half-written.
void writeOutputFile(const std::string& path, const std::string& text);

// The label of the fitted models' tracker in the tables and CSVs.
extern const char* const kFittedTracker;

// The seven sequences of Dexter 1, in the paper's order, then issue 9's harder ones (raised,
// pronation, wristflex, fastturn).
const std::vector<std::string>& benchmarkSequences();

// Parses the arguments after the program name. Throws UsageError.
BenchmarkOptions parseBenchmarkArguments(const std::vector<std::string>& args);
std::string benchmarkUsage();

// Errors of one tracked run against the ground truth.
struct RunErrors {
  std::vector<double> stamps;     // the ground-truth frames (seconds)
  std::vector<double> errors_mm;  // per ground-truth frame; +inf where the tracker had no pose
  // Per ground-truth frame, from the root parameters (OrientationError); NaN where the tracker
  // had no pose or a CSV has no root_tx..root_rz columns. A non-finite tracked pose counts as
  // 180 deg (reversed and rolled over).
  std::vector<double> forward_deg;      // wrist -> middle-knuckle directions
  std::vector<double> back_normal_deg;  // back-of-hand normals
  std::vector<double> wrist_mm;         // root positions

  void append(const RunErrors& other);
};

// Per-frame errors of the tracked CSV against the ground-truth CSV, matched by stamp (within
// 0.1 ms): the mean fingertip error (mm) and, when both CSVs have the root parameters, the
// orientation and wrist errors; `forward_in_palm` is the wrist -> middle-knuckle direction in the
// palm frame (middleKnuckleDirection of the tracked model). Throws InputError for unreadable
// files.
RunErrors matchToGroundTruth(const std::string& ground_truth_csv, const std::string& tracked_csv,
                             const Eigen::Vector3d& forward_in_palm = Eigen::Vector3d::UnitX());

// Statistics of a set of per-frame errors with failures as +inf (see the file comment).
struct ErrorStats {
  int frames = 0;                         // ground-truth frames
  int failed = 0;                         // of which without a pose
  double mean_mm = 0.0;                   // over the tracked frames (NaN if none)
  double sd_mm = 0.0;                     // over the tracked frames (NaN if none)
  std::array<double, 5> percent_below{};  // errorBoundsMm(), over all frames
  // Over the tracked frames with root parameters (NaN if none), see the file comment.
  int oriented_frames = 0;
  double reversed_pct = std::numeric_limits<double>::quiet_NaN();
  double rolled_pct = std::numeric_limits<double>::quiet_NaN();
  double wrist_mean_mm = std::numeric_limits<double>::quiet_NaN();
};
// The fingertip statistics only.
ErrorStats errorStats(const std::vector<double>& errors_mm);
// Everything, orientation included.
ErrorStats errorStats(const RunErrors& errors);

struct BenchmarkRun {
  std::string sequence;
  std::string shape = "default";  // the rendered hand (config/hand_shapes.yaml)
  std::string tracker;            // the model's label: "sag", "sog" or the file's stem
  std::vector<int> cameras;       // empty: all
  RunErrors errors;
  ErrorStats stats;
  double fps = 0.0;         // TrackBagSummary::pipelineFps()
  int pipeline_frames = 0;  // frames after the background
  double pipeline_seconds = 0.0;
  double segmentation_seconds = 0.0;
  double tracking_seconds = 0.0;
};

// The fit of one hand shape (--fitted).
struct ShapeFit {
  std::string shape;
  bool ok = false;
  std::string error;                 // why the fit failed (calibrateHand's message)
  std::string routine_bag;           // the rendered routine
  std::string model;                 // DIR/models/<shape>.yaml (empty when the fit failed)
  CalibrateHandSummary calibration;  // valid when ok
};

struct BenchmarkResults {
  std::vector<std::string> sequences;
  std::vector<std::string> shapes;
  std::vector<std::string> shape_descriptions;  // each shape's (drawn hands: what was drawn)
  std::vector<std::string> trackers;
  int rig_cameras = 0;
  std::vector<BenchmarkRun> runs;         // sequence x tracker, all cameras
  std::vector<BenchmarkRun> camera_runs;  // --camera-counts: combination x sequence x tracker
  std::vector<ShapeFit> fits;             // --fitted: one per hand shape, in the shapes' order
  std::string markdown;                   // the report (also DIR/results.md)
  double seconds = 0.0;                   // the whole benchmark
};

// Runs the benchmark and writes DIR/results.md, the CSVs and the plots. Progress lines go to
// `log` (stderr in the tool). Throws InputError for bad input.
BenchmarkResults runBenchmark(const BenchmarkOptions& options, std::ostream& log);

}  // namespace sag_hand_tracker
