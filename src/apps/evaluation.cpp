// runBenchmark: see benchmark.h.
#include "sag_hand_tracker/apps/evaluation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "sag_hand_tracker/apps/csv.h"
#include "sag_hand_tracker/apps/metrics.h"
#include "sag_hand_tracker/apps/plot.h"
#include "sag_hand_tracker/apps/render_runner.h"
#include "sag_hand_tracker/apps/room_benchmark.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/pose.h"
#include "sag_hand_tracker/ros/bag_input.h"
#include "sag_hand_tracker/ros/package_config.h"
#include "sag_hand_tracker/studio/hand_shapes.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/studio/room.h"
#include "sag_hand_tracker/studio/sequence.h"
#include "sag_hand_tracker/util/atomic_output.h"
#include "sag_hand_tracker/util/number_text.h"
#include "sag_hand_tracker/util/timing.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

const char* const kFittedTracker = "fitted";

void writeOutputFile(const std::string& path, const std::string& text) {
  AtomicOutputFile file(path, /*overwrite=*/true);
  {
    std::ofstream out(file.tempPath(), std::ios::binary | std::ios::trunc);
    out << text;
    out.close();
    if (!out) throw InputError("cannot write '" + path + "'");
  }
  file.commit();
}

namespace {

namespace fs = std::filesystem;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string trackerLabel(const std::string& model) {
  if (model == "sag" || model == "sog") return model;
  return fs::path(model).stem().string();
}

std::string displayName(const std::string& tracker) {
  if (tracker == "sag") return "SAG";
  if (tracker == "sog") return "SoG";
  if (tracker == kFittedTracker) return "SAG fitted";
  return tracker;
}

std::string cameraList(const std::vector<int>& cameras) {
  std::string text;
  for (int c : cameras) text += (text.empty() ? "" : ",") + std::to_string(c);
  return text.empty() ? "all" : text;
}

// ---- bags ---------------------------------------------------------------------------------------

struct SequenceBag {
  std::string name;   // the sequence (motion file stem)
  std::string shape;  // the hand shape
  std::string bag;
  std::string gt_csv;
  bool rendered = false;  // by this run (not reused)
};

// File stem of a sequence on a shape: the sequence alone for the default hand (the names of the
// benchmark before issue 9), `<sequence>__<shape>` otherwise.
std::string runStem(const std::string& sequence, const std::string& shape) {
  return shape == "default" ? sequence : sequence + "__" + shape;
}

std::string describeShape(const studio::StudioHand& hand) {
  std::ostringstream out;
  out.precision(9);
  const studio::HandShape& s = hand.shape;
  out << "shape " << hand.name << " scale " << s.scale << " palm " << s.palm_width << " "
      << s.palm_length << " thickness " << s.thickness << " fingers";
  for (int f = 0; f < kNumFingers; ++f) {
    out << " " << s.finger_length[f];
    for (double p : s.phalanx_length[f]) out << "/" << p;
  }
  out << " skin";
  for (const Eigen::Vector3f* c : {&hand.skin.dorsal, &hand.skin.palmar, &hand.skin.nail}) {
    out << " " << c->x() << "," << c->y() << "," << c->z();
  }
  return out.str();
}

// What a bag was rendered with; a bag is reused only when this matches.
std::string renderStamp(const RenderBagOptions& render, const studio::StudioHand& hand) {
  std::ostringstream out;
  out << "sequence " << render.sequence << "\nrig " << render.rig << "\nframes " << render.frames
      << "\nseed " << render.seed << "\nfps " << render.fps << "\n"
      << describeShape(hand) << "\n";
  return out.str();
}

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// `frames` rendered (0: the motion's full length).
// `name`: the bag's name instead of the sequence's (a fit's bag of a tracked sequence's first
// frames must not replace that sequence's bag).
SequenceBag prepareBag(const BenchmarkOptions& options, const std::string& sequence,
                       const studio::StudioHand& hand, int frames, std::ostream& log,
                       const std::string& name = "") {
  const fs::path dir = fs::path(options.out_dir) / "bags";
  fs::create_directories(dir);
  const std::string seq = name.empty() ? fs::path(sequence).stem().string() : name;
  const std::string stem = runStem(seq, hand.name);
  SequenceBag bag{seq, hand.name, (dir / (stem + ".bag")).string(),
                  (dir / (stem + "_gt.csv")).string()};
  const std::string stamp_path = (dir / (stem + ".render.txt")).string();

  RenderBagOptions render;
  render.sequence = sequence;
  render.rig = options.rig;
  render.out = bag.bag;
  render.gt_csv = bag.gt_csv;
  render.config_dir = options.config_dir;
  render.frames = frames;
  render.quiet = true;
  render.overwrite = true;  // the benchmark's own folder: --rerender replaces its bags
  // The benchmark's shapes come from the config's list; a shape file would do as well.
  render.shape = hand.name;
  const std::string stamp = renderStamp(render, hand);
  if (!options.rerender && fs::exists(bag.bag) && fs::exists(bag.gt_csv) &&
      fs::exists(stamp_path) && readFile(stamp_path) == stamp) {
    log << "benchmark: reusing " << bag.bag << "\n" << std::flush;
    return bag;
  }
  // A bag linked in from elsewhere (another run's folder, shared to save the rendering) is not
  // replaced through the link (render_bag's --overwrite follows one): the link goes, and the
  // render writes a file of this folder's own. (fs::remove takes a link, not its target.)
  for (const std::string& path : {bag.bag, bag.gt_csv}) {
    if (fs::is_symlink(path)) fs::remove(path);
  }
  fs::remove(stamp_path);
  const RenderBagSummary summary = renderStudioBag(render, nullptr);
  writeOutputFile(stamp_path, stamp);
  bag.rendered = true;
  log << "benchmark: rendered " << summary.sequence << " (hand " << hand.name
      << "): " << summary.frames << " frames x " << summary.cameras << " cameras in "
      << fixedNumber(summary.total_seconds, 1) << " s -> " << bag.bag << "\n"
      << std::flush;
  return bag;
}

// ---- one run ------------------------------------------------------------------------------------

// `label` names the tracker in the tables (trackerLabel(model) unless the model is a fitted one).
BenchmarkRun trackRun(const BenchmarkOptions& options, const SequenceBag& bag,
                      const std::string& model, const std::string& label,
                      const std::vector<int>& cameras, const std::string& out_csv) {
  TrackBagOptions track;
  track.bag = bag.bag;
  track.out = out_csv;
  track.model = model;
  track.iterations = options.iterations;
  track.cameras = cameras;
  track.config_dir = options.config_dir;
  track.quiet = true;
  track.overwrite = true;  // the benchmark's own folder: each run replaces its tracks
  const TrackBagSummary summary = trackBag(track, nullptr, nullptr);

  const std::string config = packageConfigDir(options.config_dir);
  const Eigen::Vector3d forward =
      middleKnuckleDirection(loadHandModel(resolveModelPath(model, config)));

  BenchmarkRun run;
  run.sequence = bag.name;
  run.shape = bag.shape;
  run.tracker = label;
  run.cameras = cameras;
  // No CSV when nothing was tracked (and an old one at out_csv is not this run's).
  run.errors = matchToGroundTruth(bag.gt_csv, summary.csv_written ? out_csv : "", forward);
  run.stats = errorStats(run.errors);
  run.fps = summary.pipelineFps();
  run.pipeline_frames = summary.frames - summary.background_frames;
  run.pipeline_seconds = summary.pipeline_seconds;
  run.segmentation_seconds = summary.segmentation_seconds;
  run.tracking_seconds = summary.tracking_seconds;
  return run;
}

std::string runLine(const BenchmarkRun& run) {
  std::ostringstream out;
  out << run.sequence << " " << run.shape << " " << run.tracker << " (cameras "
      << cameraList(run.cameras) << "): " << fixedNumber(run.stats.mean_mm, 1) << " mm mean, "
      << run.stats.failed << "/" << run.stats.frames << " failed, reversed "
      << fixedNumber(run.stats.reversed_pct, 1) << " %, rolled over "
      << fixedNumber(run.stats.rolled_pct, 1) << " %, wrist "
      << fixedNumber(run.stats.wrist_mean_mm, 1) << " mm, " << fixedNumber(run.fps, 0) << " fps";
  return out.str();
}

// ---- fitted models (--fitted) -------------------------------------------------------------------

// The palm's length error of a fit: the wrist's distance from the fingers' first joints, fitted /
// true - 1, averaged over the fingers.
double meanKnuckleError(const SkeletonErrors& errors) {
  double sum = 0.0;
  for (double error : errors.knuckle) sum += error;
  return sum / kNumFingers;
}

// A fraction as a signed percentage with one decimal ("+2.5", "-0.3").
std::string signedPercent(double fraction) {
  return (fraction >= 0.0 ? "+" : "") + fixedNumber(100.0 * fraction, 1);
}

// The model fitted to `hand`: renders the calibration routine on it (reused like the sequences'
// bags), runs calibrate_hand's code on that bag from the default model and moves the result to
// DIR/models/<shape>.yaml. calibrateHand writes nothing on failure and refuses an existing output,
// so it writes a staging file that replaces the model of an earlier run only once the fit is done.
// A failed fit (InputError: the routine too short or not followed) is returned, not thrown.
ShapeFit fitShape(const BenchmarkOptions& options, const studio::StudioHand& hand,
                  std::ostream& log) {
  ShapeFit fit;
  fit.shape = hand.name;
  const fs::path models = fs::path(options.out_dir) / "models";
  fs::create_directories(models);
  const fs::path model = models / (hand.name + ".yaml");
  const fs::path staging = models / ("." + hand.name + ".yaml.fitting.yaml");
  try {
    const bool routine_sequence = options.fit_sequence == "calibration_routine";
    const SequenceBag routine =
        prepareBag(options, options.fit_sequence, hand, options.routine_frames, log,
                   routine_sequence ? "" : "fit_" + fs::path(options.fit_sequence).stem().string());
    fit.routine_bag = routine.bag;
    std::error_code ignored;
    fs::remove(staging, ignored);  // a leftover of an interrupted run
    CalibrateHandOptions calibrate;
    calibrate.bag = routine.bag;
    calibrate.out = staging.string();
    calibrate.model = "sag";
    calibrate.config_dir = options.config_dir;
    calibrate.quiet = true;
    try {
      fit.calibration = calibrateHand(calibrate, nullptr);
    } catch (const InputError&) {
      if (options.discard_bags && routine.rendered) fs::remove(routine.bag, ignored);
      throw;
    }
    if (options.discard_bags && routine.rendered) fs::remove(routine.bag, ignored);
    fs::rename(staging, model);
    fit.calibration.out = model.string();
    fit.model = model.string();
    fit.ok = true;
    const HandFitResult& r = fit.calibration.fit;
    // The studio knows the hand's skeleton (render_bag shapes it from the default model): the
    // fitted bones against it, as calibrate_hand --truth-shape reports them.
    fit.calibration.truth_shape = hand.name;
    fit.calibration.truth_errors = compareSkeletons(
        r.model, studio::shapeHandModel(
                     loadHandModel(resolveModelPath("sag", packageConfigDir(options.config_dir))),
                     hand.shape));
    log << "benchmark: fitted the model to hand " << hand.name << ": from the tracker's size x"
        << fixedNumber(fit.calibration.start_size, 3) << ", size x" << fixedNumber(r.shape.scale, 3)
        << ", palm width x" << fixedNumber(r.shape.palm_width, 3) << ", finger length x"
        << fixedNumber(r.shape.finger_length, 3) << ", thickness x"
        << fixedNumber(r.shape.thickness, 3) << "; energy " << fixedNumber(r.energy_before, 4)
        << " -> " << fixedNumber(r.energy_after, 4) << "; worst bone "
        << fixedNumber(100.0 * fit.calibration.truth_errors.worst_bone, 1) << " % of the truth in "
        << fixedNumber(fit.calibration.seconds, 1) << " s -> " << fit.model << "\n"
        << std::flush;
  } catch (const std::exception& error) {
    // InputError (the routine, the bag) or fs::filesystem_error (moving the model into place).
    if (!dynamic_cast<const InputError*>(&error) &&
        !dynamic_cast<const fs::filesystem_error*>(&error)) {
      throw;
    }
    std::error_code ignored;
    fs::remove(staging, ignored);
    fit.error = error.what();
    log << "benchmark: the fit on hand " << hand.name
        << " failed (no fitted runs for it): " << fit.error << "\n"
        << std::flush;
  }
  return fit;
}

// ---- aggregation --------------------------------------------------------------------------------

struct Pooled {
  ErrorStats stats;
  double fps = 0.0;
  double segmentation_ms = 0.0;
  double tracking_ms = 0.0;
  int runs = 0;
};

Pooled pool(const std::vector<const BenchmarkRun*>& runs) {
  Pooled pooled;
  RunErrors errors;
  int frames = 0;
  double seconds = 0.0, segmentation = 0.0, tracking = 0.0;
  for (const BenchmarkRun* run : runs) {
    errors.append(run->errors);
    frames += run->pipeline_frames;
    seconds += run->pipeline_seconds;
    segmentation += run->segmentation_seconds;
    tracking += run->tracking_seconds;
  }
  pooled.stats = errorStats(errors);
  pooled.fps = seconds > 0.0 ? frames / seconds : 0.0;
  pooled.segmentation_ms = frames > 0 ? 1e3 * segmentation / frames : 0.0;
  pooled.tracking_ms = frames > 0 ? 1e3 * tracking / frames : 0.0;
  pooled.runs = static_cast<int>(runs.size());
  return pooled;
}

template <typename Predicate>
std::vector<const BenchmarkRun*> select(const std::vector<BenchmarkRun>& runs,
                                        Predicate predicate) {
  std::vector<const BenchmarkRun*> selected;
  for (const BenchmarkRun& run : runs) {
    if (predicate(run)) selected.push_back(&run);
  }
  return selected;
}

// Every combination of `k` of `n` cameras, in lexicographic order.
std::vector<std::vector<int>> combinations(int n, int k) {
  std::vector<std::vector<int>> result;
  std::vector<int> current;
  std::function<void(int)> recurse = [&](int first) {
    if (static_cast<int>(current.size()) == k) {
      result.push_back(current);
      return;
    }
    for (int c = first; c < n; ++c) {
      current.push_back(c);
      recurse(c + 1);
      current.pop_back();
    }
  };
  recurse(0);
  return result;
}

// The trackers of the Figure 6 runs: the --models (the fitted models are not run there).
std::vector<std::string> cameraTrackers(const BenchmarkResults& results) {
  std::vector<std::string> trackers;
  for (const std::string& t : results.trackers) {
    for (const BenchmarkRun& run : results.camera_runs) {
      if (run.tracker == t) {
        trackers.push_back(t);
        break;
      }
    }
  }
  return trackers;
}

// ---- report -------------------------------------------------------------------------------------

std::string markdownRow(const std::vector<std::string>& cells) {
  std::string row = "|";
  for (const std::string& cell : cells) row += " " + cell + " |";
  return row + "\n";
}

std::string markdownRule(size_t columns) {
  std::string row = "|";
  for (size_t i = 0; i < columns; ++i) row += (i == 0 ? "---|" : "---:|");
  return row + "\n";
}

// Per hand shape, the default and the fitted model side by side, with issue 10's bar.
struct FittedComparison {
  std::string shape;
  const ShapeFit* fit = nullptr;
  Pooled with_default;  // SAG, default model
  Pooled with_fitted;   // SAG, the shape's fitted model (no runs if the fit failed)
  // The bar, on the shapes but the default: the fitted model's error below the default model's,
  // and within 20 % of the default hand's error with the default model. NaN reference: no default
  // hand in the run, so the second half cannot be checked.
  double reference_mm = kNaN;
  bool lower = false;
  bool within_20_percent = false;
};

std::vector<FittedComparison> compareFitted(const BenchmarkResults& results) {
  std::vector<FittedComparison> rows;
  const Pooled reference = pool(select(results.runs, [](const BenchmarkRun& r) {
    return r.tracker == "sag" && r.shape == "default";
  }));
  for (const ShapeFit& fit : results.fits) {
    FittedComparison row;
    row.shape = fit.shape;
    row.fit = &fit;
    row.with_default = pool(select(results.runs, [&](const BenchmarkRun& r) {
      return r.tracker == "sag" && r.shape == fit.shape;
    }));
    row.with_fitted = pool(select(results.runs, [&](const BenchmarkRun& r) {
      return r.tracker == kFittedTracker && r.shape == fit.shape;
    }));
    row.reference_mm = reference.runs > 0 ? reference.stats.mean_mm : kNaN;
    const double fitted = row.with_fitted.stats.mean_mm;
    // A failed frame has no error in the mean: with more failures the means are not comparable.
    const bool no_more_failures = row.with_fitted.stats.failed <= row.with_default.stats.failed;
    row.lower = fit.ok && std::isfinite(fitted) && no_more_failures &&
                fitted < row.with_default.stats.mean_mm;
    row.within_20_percent = fit.ok && std::isfinite(fitted) && std::isfinite(row.reference_mm) &&
                            fitted <= 1.2 * row.reference_mm;
    rows.push_back(row);
  }
  return rows;
}

// A message on one table line.
std::string oneLine(std::string text) {
  std::replace(text.begin(), text.end(), '\n', ' ');
  std::replace(text.begin(), text.end(), '|', '/');
  std::replace(text.begin(), text.end(), ',', ';');  // also a CSV field
  return text;
}

std::string fittedReport(const BenchmarkOptions& options, const BenchmarkResults& results) {
  std::ostringstream md;
  const std::vector<FittedComparison> rows = compareFitted(results);
  md << "## Default model against fitted model per hand shape (mm), all sequences\n\n";
  md << "SAG with its default model and with the model fitted to each hand (`calibrate_hand`'s "
        "code on "
     << (options.fit_sequence == "calibration_routine"
             ? std::string("the calibration routine")
             : "`" + options.fit_sequence + "` (not the routine: `--fit-sequence`)")
     << " rendered on that hand, "
     << (options.routine_frames > 0 ? std::to_string(options.routine_frames) + " frames"
                                    : std::string("full length"))
     << "; DIR/models/<shape>.yaml). **bar** (issue 10, shapes but the default): the fitted "
        "model's pooled error is lower than the default model's (with no more failed frames), "
        "and within 20 % of the default hand's error with the default model ("
     << (rows.empty() || !std::isfinite(rows.front().reference_mm)
             ? std::string("not in this run")
             : fixedNumber(rows.front().reference_mm, 1) + " mm, so at most " +
                   fixedNumber(1.2 * rows.front().reference_mm, 1) + " mm")
     << ").\n\n";
  const std::vector<std::string> header{
      "hand shape",     "frames",        "default mean",  "fitted mean",  "change %",
      "default failed", "fitted failed", "default rev %", "fitted rev %", "default roll %",
      "fitted roll %",  "default wrist", "fitted wrist",  "bar"};
  md << markdownRow(header) << markdownRule(header.size());
  for (const FittedComparison& row : rows) {
    const ErrorStats& d = row.with_default.stats;
    const ErrorStats& f = row.with_fitted.stats;
    const bool ok = row.fit->ok;
    auto fitted = [&](const std::string& cell) { return ok ? cell : std::string("-"); };
    std::vector<std::string> cells{row.shape,
                                   std::to_string(d.frames),
                                   fixedNumber(d.mean_mm, 1),
                                   ok ? "**" + fixedNumber(f.mean_mm, 1) + "**" : "fit failed",
                                   fitted(fixedNumber(100.0 * (f.mean_mm / d.mean_mm - 1.0), 1)),
                                   std::to_string(d.failed),
                                   fitted(std::to_string(f.failed)),
                                   fixedNumber(d.reversed_pct, 1),
                                   fitted(fixedNumber(f.reversed_pct, 1)),
                                   fixedNumber(d.rolled_pct, 1),
                                   fitted(fixedNumber(f.rolled_pct, 1)),
                                   fixedNumber(d.wrist_mean_mm, 1),
                                   fitted(fixedNumber(f.wrist_mean_mm, 1))};
    std::string bar;
    if (row.shape == "default") {
      bar = "(reference)";
    } else if (!row.fit->ok) {
      bar = "no (fit failed)";
    } else if (!std::isfinite(row.reference_mm)) {
      bar = row.lower ? "lower; 20 %: no default hand" : "no (not lower)";
    } else if (row.lower && row.within_20_percent) {
      bar = "yes";
    } else {
      bar = std::string("no (") + (row.lower ? "" : "not lower") +
            (!row.lower && !row.within_20_percent ? ", " : "") +
            (row.within_20_percent ? "" : "above 1.2 x default hand") + ")";
    }
    cells.push_back(bar);
    md << markdownRow(cells);
  }
  md << "\n";

  md << "## The fits (calibrate_hand's code, start model `sag`)\n\n";
  const std::vector<std::string> fit_header{
      "hand shape",
      "result",
      "frames with the hand",
      "used",
      "tracker's size x",
      "size x",
      "palm width x",
      "finger length x",
      "thickness x",
      "energy before",
      "energy after",
      "score before",
      "score after",
      "tips on foreground %",
      "palm vs truth %",
      "fingers vs truth % (thumb..pinky)",
      "worst bone %",
      "bones within " + fixedNumber(100.0 * kFitBoneTolerance, 0) + " %",
      "seconds"};
  md << markdownRow(fit_header) << markdownRule(fit_header.size());
  for (const ShapeFit& fit : results.fits) {
    std::vector<std::string> cells{fit.shape};
    if (!fit.ok) {
      cells.push_back("failed: " + oneLine(fit.error));
      while (cells.size() < fit_header.size()) cells.push_back("-");
    } else {
      const CalibrateHandSummary& c = fit.calibration;
      cells.push_back("fitted");
      cells.push_back(std::to_string(c.tracked_frames));
      cells.push_back(std::to_string(c.fit.frame_indices.size()));
      cells.push_back(fixedNumber(c.start_size, 3));
      cells.push_back(fixedNumber(c.fit.shape.scale, 3));
      cells.push_back(fixedNumber(c.fit.shape.palm_width, 3));
      cells.push_back(fixedNumber(c.fit.shape.finger_length, 3));
      cells.push_back(fixedNumber(c.fit.shape.thickness, 3));
      cells.push_back(fixedNumber(c.fit.energy_before, 4));
      cells.push_back(fixedNumber(c.fit.energy_after, 4));
      cells.push_back(fixedNumber(c.fit.score_before, 4));
      cells.push_back(fixedNumber(c.fit.score_after, 4));
      cells.push_back(fixedNumber(100.0 * c.tips_on_foreground_before, 1) + " -> " +
                      fixedNumber(100.0 * c.tips_on_foreground_after, 1));
      cells.push_back(signedPercent(meanKnuckleError(c.truth_errors)));
      std::string fingers;
      for (double error : c.truth_errors.finger) {
        fingers += (fingers.empty() ? "" : " / ") + signedPercent(error);
      }
      cells.push_back(fingers);
      cells.push_back(fixedNumber(100.0 * c.truth_errors.worst_bone, 1));
      cells.push_back(std::to_string(c.truth_errors.bonesWithin(kFitBoneTolerance)) + " of " +
                      std::to_string(kNumFingers * 3));
      cells.push_back(fixedNumber(c.seconds, 1));
    }
    md << markdownRow(cells);
  }
  md << "\n(The factors are relative to the default model; energy: the mean tracking energy E "
        "over the frames the fit used; fingers vs truth: each finger's fitted length (its bones "
        "summed) against the rendered hand's, fitted / true - 1, palm: the same of the wrist's "
        "distance from the fingers' first joints, averaged; worst bone: the largest such "
        "error of a single finger bone, issue 10's bar being 5 %; seconds: the fit with its "
        "tracking of the routine, rendering excluded.)\n\n";
  return md.str();
}

std::string report(const BenchmarkOptions& options, const BenchmarkResults& results,
                   const std::map<int, int>& combinations_per_count) {
  std::ostringstream md;
  const auto& trackers = results.trackers;
  const bool several_shapes = results.shapes.size() > 1;
  std::string shape_list;
  bool drawn_hands = false;
  for (const std::string& shape : results.shapes) {
    shape_list += (shape_list.empty() ? "" : ", ") + ("`" + shape + "`");
    drawn_hands = drawn_hands || studio::drawnHandSeed(shape) >= 0;
  }
  md << "# Benchmark: SAG against SoG on the synthetic studio\n\n";
  md << "Rig `" << options.rig << "` (" << results.rig_cameras << " cameras), "
     << options.iterations << " optimiser iterations per frame, "
     << (options.frames > 0 ? std::to_string(options.frames) + " frames per sequence"
                            : std::string("full-length sequences"))
     << "; rendered hand" << (several_shapes ? "s " : " ") << shape_list
     << (drawn_hands ? " (config/hand_shapes.yaml, or drawn at random: listed below"
                     : " (config/hand_shapes.yaml")
     << "; the trackers keep their default models"
     << (results.fits.empty() ? ""
                              : "; **SAG fitted**: SAG with the model fitted by calibrate_hand's "
                                "code to the calibration routine rendered on the same hand")
     << "). Error: mean over "
        "the 5 fingertips per frame (mm), against the rendered ground truth. "
        "A frame without a pose (before the start, or lost) is a failed frame: left out of the "
        "mean and sd, counted against every bound of Table 1. **rev %**: tracked frames whose "
        "wrist -> middle-knuckle direction is more than 90 deg from the truth's (reversed hand); "
        "**roll %**: tracked frames whose back-of-hand normal is more than 90 deg from the "
        "truth's (rolled over); **wrist**: mean wrist (root position) error of the tracked frames "
        "(mm).\n\n";
  // Hands drawn at random are known by their seed only: say what was drawn.
  for (size_t h = 0; h < results.shapes.size() && h < results.shape_descriptions.size(); ++h) {
    if (studio::drawnHandSeed(results.shapes[h]) < 0) continue;
    md << "- `" << results.shapes[h] << "`: " << results.shape_descriptions[h] << "\n";
  }
  if (drawn_hands) md << "\n";

  // Error tables: one row per selection of runs, the columns of every tracker.
  std::vector<std::string> columns{"frames"};
  for (const std::string& t : trackers) {
    for (const char* c : {" mean", " sd", " failed", " rev %", " roll %", " wrist"}) {
      columns.push_back(displayName(t) + c);
    }
  }
  auto errorCells = [&](const std::string& label,
                        const std::function<bool(const BenchmarkRun&)>& in) {
    std::vector<std::string> cells{label, ""};
    for (const std::string& t : trackers) {
      const Pooled p = pool(
          select(results.runs, [&](const BenchmarkRun& r) { return r.tracker == t && in(r); }));
      cells[1] = std::to_string(p.stats.frames);
      cells.push_back(fixedNumber(p.stats.mean_mm, 1));
      cells.push_back(fixedNumber(p.stats.sd_mm, 1));
      cells.push_back(std::to_string(p.stats.failed));
      cells.push_back(fixedNumber(p.stats.reversed_pct, 1));
      cells.push_back(fixedNumber(p.stats.rolled_pct, 1));
      cells.push_back(fixedNumber(p.stats.wrist_mean_mm, 1));
    }
    return cells;
  };
  auto header = [&](const std::string& first) {
    std::vector<std::string> h{first};
    h.insert(h.end(), columns.begin(), columns.end());
    return markdownRow(h) + markdownRule(h.size());
  };
  const auto everything = [](const BenchmarkRun&) { return true; };
  md << "## Fingertip error per sequence (mm)" << (several_shapes ? ", all hand shapes" : "")
     << "\n\n";
  md << header("sequence");
  for (const std::string& s : results.sequences) {
    md << markdownRow(errorCells(s, [&](const BenchmarkRun& r) { return r.sequence == s; }));
  }
  md << markdownRow(errorCells("**all**", everything));
  md << "\n(**all**: over every frame of every sequence"
     << (several_shapes ? " and hand shape" : "") << ".)\n\n";

  if (several_shapes) {
    md << "## Fingertip error per hand shape (mm), all sequences\n\n";
    md << header("hand shape");
    for (const std::string& h : results.shapes) {
      md << markdownRow(errorCells(h, [&](const BenchmarkRun& r) { return r.shape == h; }));
    }
    md << markdownRow(errorCells("**all**", everything)) << "\n";

    // Per tracker: sequence x shape matrices of the mean error and of the orientation failures.
    for (const std::string& t : trackers) {
      auto matrix = [&](const std::string& title,
                        const std::function<std::string(const ErrorStats&)>& cell) {
        md << "## " << displayName(t) << ": " << title << " per sequence and hand shape\n\n";
        std::vector<std::string> h{"sequence"};
        h.insert(h.end(), results.shapes.begin(), results.shapes.end());
        h.push_back("all shapes");
        md << markdownRow(h) << markdownRule(h.size());
        std::vector<std::string> rows = results.sequences;
        rows.push_back("**all**");
        for (const std::string& s : rows) {
          std::vector<std::string> cells{s};
          std::vector<std::string> shapes = results.shapes;
          shapes.push_back("");
          for (const std::string& h : shapes) {
            const Pooled p = pool(select(results.runs, [&](const BenchmarkRun& r) {
              return r.tracker == t && (s == "**all**" || r.sequence == s) &&
                     (h.empty() || r.shape == h);
            }));
            cells.push_back(cell(p.stats));
          }
          md << markdownRow(cells);
        }
        md << "\n";
      };
      matrix("mean fingertip error (mm)",
             [](const ErrorStats& st) { return fixedNumber(st.mean_mm, 1); });
      matrix("reversed % / rolled-over %", [](const ErrorStats& st) {
        return fixedNumber(st.reversed_pct, 1) + " / " + fixedNumber(st.rolled_pct, 1);
      });
    }
  }

  if (!results.fits.empty()) md << fittedReport(options, results);

  // Table 1: rows = bounds, columns = sequence x tracker (SoG beside SAG as in the paper).
  std::vector<std::string> ordered = trackers;
  std::stable_sort(ordered.begin(), ordered.end(), [](const std::string& a, const std::string& b) {
    return (a == "sog" ? 0 : a == "sag" ? 1 : 2) < (b == "sog" ? 0 : b == "sag" ? 1 : 2);
  });
  md << "## Table 1: % of frames with an error below x mm\n\n";
  std::vector<std::string> t1{"x (mm)"};
  for (const std::string& s : results.sequences) {
    for (const std::string& t : ordered) t1.push_back(s + " " + displayName(t));
  }
  md << markdownRow(t1) << markdownRule(t1.size());
  for (size_t b = 0; b < errorBoundsMm().size(); ++b) {
    std::vector<std::string> cells{fixedNumber(errorBoundsMm()[b], 0)};
    for (const std::string& s : results.sequences) {
      for (const std::string& t : ordered) {
        const Pooled p = pool(select(results.runs, [&](const BenchmarkRun& r) {
          return r.tracker == t && r.sequence == s;
        }));
        cells.push_back(fixedNumber(p.stats.percent_below[b], 1));
      }
    }
    md << markdownRow(cells);
  }
  md << "\n";

  // Speed.
  md << "## Speed (frames per second, single thread; segmentation + optimisation, decode "
        "excluded)\n\n";
  std::vector<std::string> sh{"sequence"};
  for (const std::string& t : trackers) sh.push_back(displayName(t) + " fps");
  md << markdownRow(sh) << markdownRule(sh.size());
  for (const std::string& s : results.sequences) {
    std::vector<std::string> cells{s};
    for (const std::string& t : trackers) {
      cells.push_back(fixedNumber(
          pool(select(results.runs,
                      [&](const BenchmarkRun& r) { return r.tracker == t && r.sequence == s; }))
              .fps,
          0));
    }
    md << markdownRow(cells);
  }
  std::vector<std::string> all_cells{"**all**"};
  std::ostringstream per_frame;
  for (const std::string& t : trackers) {
    const Pooled p =
        pool(select(results.runs, [&](const BenchmarkRun& r) { return r.tracker == t; }));
    all_cells.push_back(fixedNumber(p.fps, 0));
    per_frame << (per_frame.tellp() > 0 ? "; " : "") << displayName(t) << ": segmentation "
              << fixedNumber(p.segmentation_ms, 2) << " ms + optimisation "
              << fixedNumber(p.tracking_ms, 2) << " ms per frame";
  }
  md << markdownRow(all_cells) << "\n" << per_frame.str() << ".\n\n";

  // Figure 6.
  if (!results.camera_runs.empty()) {
    std::set<std::string> seqs;
    for (const BenchmarkRun& r : results.camera_runs) seqs.insert(r.sequence);
    std::string seq_list;
    for (const std::string& s : results.sequences) {
      if (seqs.count(s)) seq_list += (seq_list.empty() ? "" : ", ") + s;
    }
    md << "## Figure 6: error against the number of cameras\n\n";
    md << "Every combination of the cameras, on " << seq_list
       << "; mean and sd over every frame of every combination and sequence.\n\n";
    std::vector<std::string> ch{"cameras", "combinations"};
    for (const std::string& t : cameraTrackers(results)) {
      ch.push_back(displayName(t) + " mean");
      ch.push_back(displayName(t) + " sd");
      ch.push_back(displayName(t) + " failed %");
    }
    md << markdownRow(ch) << markdownRule(ch.size());
    for (const auto& [count, combos] : combinations_per_count) {
      std::vector<std::string> cells{std::to_string(count), std::to_string(combos)};
      for (const std::string& t : cameraTrackers(results)) {
        const Pooled p = pool(select(results.camera_runs, [&](const BenchmarkRun& r) {
          return r.tracker == t && static_cast<int>(r.cameras.size()) == count;
        }));
        cells.push_back(fixedNumber(p.stats.mean_mm, 1));
        cells.push_back(fixedNumber(p.stats.sd_mm, 1));
        cells.push_back(
            fixedNumber(p.stats.frames > 0 ? 100.0 * p.stats.failed / p.stats.frames : kNaN, 1));
      }
      md << markdownRow(cells);
    }
    md << "\n";
  }
  return md.str();
}

// One row per sequence, shape and tracker, then the pooled rows: per sequence over the shapes
// (shape "all"), per shape over the sequences (sequence "all"), and over everything ("all",
// "all"). Without several shapes only the per-run rows and the "all,all" rows.
void writeResultsCsv(const std::string& path, const BenchmarkResults& results) {
  std::ostringstream out;
  out << "sequence,shape,tracker,frames,mean_mm,sd_mm,pct15,pct20,pct25,pct30,pct45,fps,failed,"
         "reversed_pct,rolled_pct,wrist_mm\n";
  auto row = [&](const std::string& sequence, const std::string& shape, const std::string& tracker,
                 const ErrorStats& stats, double fps) {
    out << sequence << "," << shape << "," << tracker << "," << stats.frames << ","
        << fixedNumber(stats.mean_mm, 3) << "," << fixedNumber(stats.sd_mm, 3);
    for (double p : stats.percent_below) out << "," << fixedNumber(p, 2);
    out << "," << fixedNumber(fps, 1) << "," << stats.failed << ","
        << fixedNumber(stats.reversed_pct, 2) << "," << fixedNumber(stats.rolled_pct, 2) << ","
        << fixedNumber(stats.wrist_mean_mm, 3) << "\n";
  };
  for (const BenchmarkRun& run : results.runs) {
    row(run.sequence, run.shape, run.tracker, run.stats, run.fps);
  }
  for (const std::string& t : results.trackers) {
    if (results.shapes.size() > 1) {
      for (const std::string& s : results.sequences) {
        const Pooled p = pool(select(results.runs, [&](const BenchmarkRun& r) {
          return r.tracker == t && r.sequence == s;
        }));
        row(s, "all", t, p.stats, p.fps);
      }
      for (const std::string& h : results.shapes) {
        const Pooled p = pool(select(
            results.runs, [&](const BenchmarkRun& r) { return r.tracker == t && r.shape == h; }));
        row("all", h, t, p.stats, p.fps);
      }
    }
    const Pooled p =
        pool(select(results.runs, [&](const BenchmarkRun& r) { return r.tracker == t; }));
    row("all", "all", t, p.stats, p.fps);
  }
  writeOutputFile(path, out.str());
}

// --fitted: one row per hand shape, the default and the fitted model pooled over the sequences,
// the bar's two halves and the fit's summary.
void writeFittedCsv(const std::string& path, const BenchmarkResults& results) {
  std::ostringstream out;
  out << "shape,fit,frames,default_mean_mm,fitted_mean_mm,default_failed,fitted_failed,"
         "default_reversed_pct,fitted_reversed_pct,default_rolled_pct,fitted_rolled_pct,"
         "default_wrist_mm,fitted_wrist_mm,reference_mm,fitted_lower,fitted_within_20pct,"
         "fit_tracked_frames,fit_used_frames,fit_start_size,fit_scale,fit_palm_width,"
         "fit_finger_length,fit_thickness,energy_before,energy_after,score_before,score_after,"
         "fit_palm_pct,fit_thumb_pct,fit_index_pct,fit_middle_pct,fit_ring_pct,fit_pinky_pct,"
         "fit_worst_bone_pct,fit_bones_within_5pct,fit_seconds,model,"
         "error\n";
  for (const FittedComparison& row : compareFitted(results)) {
    const ErrorStats& d = row.with_default.stats;
    const ErrorStats& f = row.with_fitted.stats;
    const ShapeFit& fit = *row.fit;
    const CalibrateHandSummary& c = fit.calibration;
    auto ifFitted = [&](double value, int decimals) {
      return fit.ok ? fixedNumber(value, decimals) : std::string("-");
    };
    out << row.shape << "," << (fit.ok ? "ok" : "failed") << "," << d.frames << ","
        << fixedNumber(d.mean_mm, 3) << "," << ifFitted(f.mean_mm, 3) << "," << d.failed << ","
        << (fit.ok ? std::to_string(f.failed) : "-") << "," << fixedNumber(d.reversed_pct, 2) << ","
        << ifFitted(f.reversed_pct, 2) << "," << fixedNumber(d.rolled_pct, 2) << ","
        << ifFitted(f.rolled_pct, 2) << "," << fixedNumber(d.wrist_mean_mm, 3) << ","
        << ifFitted(f.wrist_mean_mm, 3) << "," << fixedNumber(row.reference_mm, 3) << ","
        << (row.lower ? 1 : 0) << "," << (row.within_20_percent ? 1 : 0) << ","
        << (fit.ok ? std::to_string(c.tracked_frames) : "-") << ","
        << (fit.ok ? std::to_string(c.fit.frame_indices.size()) : "-") << ","
        << ifFitted(c.start_size, 4) << "," << ifFitted(c.fit.shape.scale, 4) << ","
        << ifFitted(c.fit.shape.palm_width, 4) << "," << ifFitted(c.fit.shape.finger_length, 4)
        << "," << ifFitted(c.fit.shape.thickness, 4) << "," << ifFitted(c.fit.energy_before, 5)
        << "," << ifFitted(c.fit.energy_after, 5) << "," << ifFitted(c.fit.score_before, 5) << ","
        << ifFitted(c.fit.score_after, 5) << ",";
    out << ifFitted(100.0 * meanKnuckleError(c.truth_errors), 2) << ",";
    for (double error : c.truth_errors.finger) out << ifFitted(100.0 * error, 2) << ",";
    out << ifFitted(100.0 * c.truth_errors.worst_bone, 2) << ","
        << (fit.ok ? std::to_string(c.truth_errors.bonesWithin(kFitBoneTolerance)) : "-") << ","
        << ifFitted(c.seconds, 1) << "," << fit.model << "," << oneLine(fit.error) << "\n";
  }
  writeOutputFile(path, out.str());
}

void writeCameraCsvs(const std::string& dir, const BenchmarkResults& results,
                     const std::map<int, int>& combinations_per_count) {
  const std::string counts_path = dir + "/camera_counts.csv";
  std::ostringstream counts;
  counts << "tracker,cameras,combinations,runs,frames,failed,mean_mm,sd_mm\n";
  for (const std::string& t : cameraTrackers(results)) {
    for (const auto& [count, combos] : combinations_per_count) {
      const Pooled p = pool(select(results.camera_runs, [&](const BenchmarkRun& r) {
        return r.tracker == t && static_cast<int>(r.cameras.size()) == count;
      }));
      counts << t << "," << count << "," << combos << "," << p.runs << "," << p.stats.frames << ","
             << p.stats.failed << "," << fixedNumber(p.stats.mean_mm, 3) << ","
             << fixedNumber(p.stats.sd_mm, 3) << "\n";
    }
  }
  const std::string runs_path = dir + "/camera_combinations.csv";
  writeOutputFile(counts_path, counts.str());
  std::ostringstream runs;
  runs << "sequence,tracker,cameras,frames,failed,mean_mm,sd_mm,fps\n";
  for (const BenchmarkRun& r : results.camera_runs) {
    std::string cams = cameraList(r.cameras);
    std::replace(cams.begin(), cams.end(), ',', ' ');
    runs << r.sequence << "," << r.tracker << "," << cams << "," << r.stats.frames << ","
         << r.stats.failed << "," << fixedNumber(r.stats.mean_mm, 3) << ","
         << fixedNumber(r.stats.sd_mm, 3) << "," << fixedNumber(r.fps, 1) << "\n";
  }
  writeOutputFile(runs_path, runs.str());
}

cv::Scalar trackerColour(const std::string& tracker, size_t index) {
  if (tracker == "sag") return cv::Scalar(40, 40, 220);   // red (BGR)
  if (tracker == "sog") return cv::Scalar(200, 120, 30);  // blue
  static const cv::Scalar others[] = {cv::Scalar(40, 160, 40), cv::Scalar(150, 40, 150)};
  return others[index % 2];
}

void writePlots(const std::string& dir, const BenchmarkResults& results,
                const std::map<int, int>& combinations_per_count) {
  // Per frame, on one hand (the default one when it was run, else the first): the fingertip
  // error, and the orientation angles whose excursions above 90 deg are the reversed and
  // rolled-over frames.
  const std::string hand =
      std::find(results.shapes.begin(), results.shapes.end(), "default") != results.shapes.end()
          ? std::string("default")
          : results.shapes.front();
  const std::string on_hand = results.shapes.size() > 1 ? " (hand " + hand + ")" : "";
  std::vector<cv::Mat> panels, orientation_panels;
  for (const std::string& s : results.sequences) {
    std::vector<PlotSeries> series, angles;
    std::ostringstream rates;
    for (size_t i = 0; i < results.trackers.size(); ++i) {
      const std::string& t = results.trackers[i];
      for (const BenchmarkRun& run : results.runs) {
        if (run.sequence != s || run.tracker != t || run.shape != hand) continue;
        PlotSeries line;
        line.label = displayName(t) + " (" + fixedNumber(run.stats.mean_mm, 1) + " mm)";
        line.colour = trackerColour(t, i);
        // The normal's line is unlabelled (lighter colour) so that the legend stays small.
        PlotSeries forward, normal;
        forward.label = displayName(t) + " axis (light: normal)";
        rates << (rates.tellp() > 0 ? ", " : "") << displayName(t) << " rev "
              << fixedNumber(run.stats.reversed_pct, 0) << " % roll "
              << fixedNumber(run.stats.rolled_pct, 0) << " %";
        forward.colour = line.colour;
        normal.colour = line.colour * 0.5 + cv::Scalar(128, 128, 128);
        for (size_t k = 0; k < run.errors.errors_mm.size(); ++k) {
          line.x.push_back(static_cast<double>(k));
          const double e = run.errors.errors_mm[k];
          line.y.push_back(std::isfinite(e) ? e : kNaN);  // failed frames: a gap
          forward.x.push_back(static_cast<double>(k));
          forward.y.push_back(run.errors.forward_deg[k]);
          normal.x.push_back(static_cast<double>(k));
          normal.y.push_back(run.errors.back_normal_deg[k]);
        }
        series.push_back(line);
        angles.push_back(forward);
        angles.push_back(normal);
      }
    }
    if (series.empty()) continue;
    panels.push_back(linePlot(series, s + on_hand + ": fingertip error per frame (gaps: no pose)",
                              "frame (with the hand)", "error (mm)", 900, 260));
    PlotSeries threshold;  // the 90 deg line: above it a frame is reversed / rolled over
    threshold.x = {0.0, static_cast<double>(series.front().x.size())};
    threshold.y = {90.0, 90.0};
    threshold.colour = cv::Scalar(0, 0, 0);
    angles.push_back(threshold);
    PlotSeries range;  // the axis up to 180 deg
    range.x = {0.0, 0.0};
    range.y = {180.0 / 1.05, kNaN};
    angles.push_back(range);
    orientation_panels.push_back(linePlot(angles, s + on_hand + ": angle to truth; " + rates.str(),
                                          "frame (with the hand)", "angle (deg)", 900, 300));
  }
  if (!panels.empty()) writePng(dir + "/error_per_frame.png", stackVertically(panels));
  if (!orientation_panels.empty()) {
    writePng(dir + "/orientation_per_frame.png", stackVertically(orientation_panels));
  }

  // Per hand shape (x: the shape's index in the tables), pooled over the sequences.
  if (results.shapes.size() > 1) {
    std::vector<PlotSeries> series;
    for (size_t i = 0; i < results.trackers.size(); ++i) {
      const std::string& t = results.trackers[i];
      PlotSeries mean, reversed, rolled;
      mean.label = displayName(t) + " mean (mm)";  // short: the legend box is narrow
      reversed.label = displayName(t) + " reversed %";
      rolled.label = displayName(t) + " rolled %";
      mean.colour = trackerColour(t, i);
      reversed.colour = mean.colour * 0.6;
      rolled.colour = mean.colour * 0.4 + cv::Scalar(150, 150, 150);
      for (size_t h = 0; h < results.shapes.size(); ++h) {
        const Pooled p = pool(select(results.runs, [&](const BenchmarkRun& r) {
          return r.tracker == t && r.shape == results.shapes[h];
        }));
        for (PlotSeries* line : {&mean, &reversed, &rolled}) {
          line->x.push_back(static_cast<double>(h + 1));
          line->error_bars.push_back(0.0);  // dots on the values
        }
        mean.y.push_back(p.stats.mean_mm);
        reversed.y.push_back(p.stats.reversed_pct);
        rolled.y.push_back(p.stats.rolled_pct);
      }
      series.push_back(mean);
      series.push_back(reversed);
      series.push_back(rolled);
    }
    std::string names;
    for (size_t h = 0; h < results.shapes.size(); ++h) {
      names += (h ? ", " : "") + std::to_string(h + 1) + " " + results.shapes[h];
    }
    writePng(dir + "/shapes.png", linePlot(series, "All sequences per hand shape: " + names,
                                           "hand shape", "mm / %", 1400, 420));
  }

  if (!results.camera_runs.empty()) {
    std::vector<PlotSeries> series;
    const std::vector<std::string> trackers = cameraTrackers(results);
    for (size_t i = 0; i < trackers.size(); ++i) {
      const std::string& t = trackers[i];
      PlotSeries line;
      line.label = displayName(t);
      line.colour = trackerColour(t, i);
      // Side by side, so that the error bars do not hide each other.
      const double offset = 0.06 * (static_cast<double>(i) - 0.5 * (trackers.size() - 1));
      for (const auto& entry : combinations_per_count) {
        const int count = entry.first;
        const Pooled p = pool(select(results.camera_runs, [&](const BenchmarkRun& r) {
          return r.tracker == t && static_cast<int>(r.cameras.size()) == count;
        }));
        line.x.push_back(count + offset);
        line.y.push_back(p.stats.mean_mm);
        line.error_bars.push_back(std::isfinite(p.stats.sd_mm) ? p.stats.sd_mm : 0.0);
      }
      series.push_back(line);
    }
    // An unlabelled series without points that widens the x axis by one camera on each side,
    // so that the ticks fall on whole numbers of cameras.
    PlotSeries range;
    range.x = {combinations_per_count.begin()->first - 1.0,
               combinations_per_count.rbegin()->first + 1.0};
    range.y = {kNaN, kNaN};
    series.push_back(range);
    writePng(dir + "/camera_counts.png",
             linePlot(series, "Fingertip error vs number of cameras (mean, sd bars)",
                      "number of cameras", "error (mm)", 700, 420));
  }
}

// Throws UsageError "<option> names '<name>' twice" for the first name that `names` holds twice.
void rejectNamesGivenTwice(const std::string& option, const std::vector<std::string>& names) {
  std::set<std::string> seen;
  for (const std::string& name : names) {
    if (!seen.insert(name).second) throw UsageError(option + " names '" + name + "' twice");
  }
}

}  // namespace

const std::vector<std::string>& benchmarkSequences() {
  static const std::vector<std::string> sequences = [] {
    std::vector<std::string> all = studio::builtinMotionNames();
    const auto& hard = studio::hardMotionNames();
    all.insert(all.end(), hard.begin(), hard.end());
    return all;
  }();
  return sequences;
}

std::string benchmarkUsage() {
  return R"(Usage: benchmark [options]

Renders the studio sequences on each hand shape (render_bag's code), tracks each with SAG and
with SoG (track_bag's code), and prints the fingertip error, the reversed and rolled-over frames
and the wrist error per sequence and per hand shape, the paper's Table 1, the speed, and with
--camera-counts the paper's Figure 6. Writes DIR/results.md, the CSVs and PNG plots.

Options:
  --sequences a,b,..   sequences (names or motion files; default: adbadd fingercount fingerwave
                       flexex1 pinch random tigergrasp raised pronation wristflex fastturn
                       natural)
  --shapes a,b,..      rendered hands from config/hand_shapes.yaml (default: all of them; with
                       --rooms: the default hand), or drawn<N>: a hand drawn at random with
                       seed N; the trackers keep their default models
  --drawn-hands N      also the hands drawn1..drawnN (without --shapes: only those): hands no
                       setting was tuned on
  --camera-counts      also track every combination of 2..N of the N cameras, on the Dexter 1
                       sequences but random, on the default hand (Figure 6)
  --frames N           render N frames per sequence, the first 10 without the hand (full length)
  --out-dir DIR        where the bags, tracks, tables and plots go (benchmark)
  --csv FILE           the per-sequence CSV (DIR/results.csv)
  --rig R              camera rig (dexter5)
  --iterations N       optimiser iterations per frame (20)
  --models a,b         models to compare (sag,sog; or model files)
  --reuse              reuse the bags in DIR/bags rendered with the same settings (default)
  --rerender           render the bags again
  --discard-bags       remove each bag this run rendered once it is tracked (a full run renders
                       84 bags of ~350 MB; the ground-truth CSVs and tracks stay)
  --config-dir DIR     the built-in motions, rigs and models (the package's config/)
  --no-plots           no PNG plots
  --fitted             per hand shape, also fit the model to the calibration routine rendered
                       on that hand (calibrate_hand's code; DIR/models/<shape>.yaml) and track
                       every sequence of the hand with it: the tracker "fitted" beside SAG with
                       the default model (needs sag among --models); DIR/fitted.csv. With
                       --rooms: each hand's model fitted in the clean studio, tracked in the
                       rooms with its own skin gate and with the generic one
  --routine-frames N   frames of the rendered calibration routine (its full length, 125)
  --fit-sequence NAME  fit from this motion instead of the routine (with --routine-frames 75:
                       its first 3 s, what calibrate_hand gets from the start of a recording)
  --rooms a,b|all      the studio rooms (office, kitchen, daylight) against the clean studio,
                       on each hand of --shapes and --drawn-hands: skin gate and plate, without
                       and with the room cues; foreground precision and recall, fingertip
                       error; DIR/rooms.md, rooms.csv, rooms/*.png (sequences: adbadd,pinch
                       unless --sequences)
  --room-configs a,b   the room runs to make (skin, skin+cues, plate, plate+cues; default all)
  --help               this text
)";
}

BenchmarkOptions parseBenchmarkArguments(const std::vector<std::string>& args) {
  BenchmarkOptions options;
  rejectRepeatedOptions(args);
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    auto value = [&]() -> const std::string& { return nextOptionValue(args, &i); };
    if (arg == "--help" || arg == "-h") {
      options.help = true;
    } else if (arg == "--sequences") {
      options.sequences = parseListOption(arg, value());
    } else if (arg == "--shapes") {
      options.shapes = parseListOption(arg, value());
    } else if (arg == "--drawn-hands") {
      options.drawn_hands = parseIntOption(arg, value(), 1);
    } else if (arg == "--discard-bags") {
      options.discard_bags = true;
    } else if (arg == "--camera-counts") {
      options.camera_counts = true;
    } else if (arg == "--frames") {
      options.frames = parseIntOption(arg, value(), 1);
    } else if (arg == "--out-dir") {
      options.out_dir = value();
    } else if (arg == "--csv") {
      options.csv = value();
    } else if (arg == "--rig") {
      options.rig = value();
    } else if (arg == "--iterations") {
      options.iterations = parseIntOption(arg, value(), 1);
    } else if (arg == "--models") {
      options.models = parseListOption(arg, value());
    } else if (arg == "--reuse") {
      options.rerender = false;
    } else if (arg == "--rerender") {
      options.rerender = true;
    } else if (arg == "--config-dir") {
      options.config_dir = value();
    } else if (arg == "--no-plots") {
      options.plots = false;
    } else if (arg == "--rooms") {
      options.rooms = parseListOption(arg, value());
    } else if (arg == "--room-configs") {
      const std::vector<std::string> known = BenchmarkOptions().room_configs;  // all runs
      options.room_configs = parseListOption(arg, value());
      for (const std::string& name : options.room_configs) {
        if (std::find(known.begin(), known.end(), name) == known.end()) {
          throw UsageError("--room-configs: unknown run '" + name +
                           "' (expected skin, skin+cues, plate or plate+cues)");
        }
      }
    } else if (arg == "--fitted") {
      options.fitted = true;
    } else if (arg == "--routine-frames") {
      options.routine_frames = parseIntOption(arg, value(), 1);
    } else if (arg == "--fit-sequence") {
      options.fit_sequence = value();
    } else {
      throw UsageError("unknown argument '" + arg + "'");
    }
  }
  // Options the chosen benchmark does not use were ignored without a word (--room-configs without
  // --rooms ran the hand shapes' benchmark; --shapes, --camera-counts and --csv with --rooms were
  // not run or written).
  auto given = [&](const std::string& option) {
    return std::find(args.begin(), args.end(), option) != args.end();
  };
  if (options.rooms.empty() && given("--room-configs")) {
    throw UsageError("--room-configs selects runs of --rooms; give --rooms too");
  }
  if (!options.rooms.empty()) {
    for (const std::string option : {"--camera-counts", "--csv"}) {
      if (given(option)) {
        throw UsageError(option + " is not used with --rooms (the rooms write rooms.md and " +
                         "rooms.csv)");
      }
    }
  }
  if (options.sequences.empty() && !options.rooms.empty()) options.sequences = {"adbadd", "pinch"};
  if (options.sequences.empty()) options.sequences = benchmarkSequences();
  std::vector<std::string> labels;
  for (const std::string& model : options.models) labels.push_back(trackerLabel(model));
  rejectNamesGivenTwice("--models", labels);
  for (int seed = 1; seed <= options.drawn_hands; ++seed) {
    options.shapes.push_back("drawn" + std::to_string(seed));
  }
  rejectNamesGivenTwice("--shapes", options.shapes);
  // A sequence, room or run named twice was run twice: its bags and tracks are named after the
  // sequence's file name (pinch and motions/pinch.yaml are one), its rows doubled in the tables.
  std::vector<std::string> sequence_stems;
  for (const std::string& sequence : options.sequences) {
    sequence_stems.push_back(fs::path(sequence).stem().string());
  }
  rejectNamesGivenTwice("--sequences", sequence_stems);
  std::vector<std::string> rooms;
  for (const std::string& room : options.rooms) {
    if (room == "all") {
      for (const std::string& name : studio::builtinRoomNames()) rooms.push_back(name);
    } else {
      rooms.push_back(room);
    }
  }
  rejectNamesGivenTwice("--rooms", rooms);
  rejectNamesGivenTwice("--room-configs", options.room_configs);
  if (options.frames > 0 && options.frames <= 10) {
    throw UsageError("--frames must be more than the 10 frames without the hand");
  }
  if (options.fitted) {
    if (std::count(labels.begin(), labels.end(), kFittedTracker) > 0) {
      throw UsageError(std::string("--fitted labels its runs '") + kFittedTracker +
                       "': a model of --models has that name");
    }
    if (std::count(labels.begin(), labels.end(), "sag") == 0) {
      throw UsageError(
          "--fitted compares with SAG's default model, the fit's start: --models "
          "must include sag");
    }
  }
  return options;
}

void RunErrors::append(const RunErrors& other) {
  stamps.insert(stamps.end(), other.stamps.begin(), other.stamps.end());
  errors_mm.insert(errors_mm.end(), other.errors_mm.begin(), other.errors_mm.end());
  forward_deg.insert(forward_deg.end(), other.forward_deg.begin(), other.forward_deg.end());
  back_normal_deg.insert(back_normal_deg.end(), other.back_normal_deg.begin(),
                         other.back_normal_deg.end());
  wrist_mm.insert(wrist_mm.end(), other.wrist_mm.begin(), other.wrist_mm.end());
}

namespace {

// Whether the CSV's first six parameters are the root's (root_tx .. root_rz).
bool hasRootParameters(const TrackingCsv& csv) {
  static const char* const kRoot[] = {"root_tx", "root_ty", "root_tz",
                                      "root_rx", "root_ry", "root_rz"};
  if (csv.parameter_names.size() < 6) return false;
  for (int i = 0; i < 6; ++i) {
    if (csv.parameter_names[i] != kRoot[i]) return false;
  }
  return true;
}

}  // namespace

RunErrors matchToGroundTruth(const std::string& ground_truth_csv, const std::string& tracked_csv,
                             const Eigen::Vector3d& forward_in_palm) {
  const TrackingCsv truth = readTrackingCsv(ground_truth_csv);
  TrackingCsv tracked = tracked_csv.empty() ? TrackingCsv() : readTrackingCsv(tracked_csv);
  const bool oriented = hasRootParameters(truth) && hasRootParameters(tracked);
  std::sort(tracked.rows.begin(), tracked.rows.end(),
            [](const TrackingCsvRow& a, const TrackingCsvRow& b) { return a.stamp < b.stamp; });
  RunErrors errors;
  for (const TrackingCsvRow& gt : truth.rows) {
    errors.stamps.push_back(gt.stamp);
    const auto it =
        std::lower_bound(tracked.rows.begin(), tracked.rows.end(), gt.stamp - 1e-4,
                         [](const TrackingCsvRow& row, double stamp) { return row.stamp < stamp; });
    double forward = kNaN, normal = kNaN, wrist = kNaN;
    if (it != tracked.rows.end() && std::fabs(it->stamp - gt.stamp) <= 1e-4) {
      errors.errors_mm.push_back(1e3 * meanFingertipError(it->fingertips, gt.fingertips));
      if (oriented) {
        const Eigen::VectorXd& q = it->parameters;
        const Eigen::VectorXd& t = gt.parameters;
        const OrientationError e =
            orientationError(rotationFromVector(q.segment<3>(3)), q.segment<3>(0),
                             rotationFromVector(t.segment<3>(3)), t.segment<3>(0), forward_in_palm);
        // A non-finite tracked pose is a failure of both kinds, never a NaN that drops out.
        forward = std::isfinite(e.forward_deg) ? e.forward_deg : 180.0;
        normal = std::isfinite(e.back_normal_deg) ? e.back_normal_deg : 180.0;
        wrist = std::isfinite(e.wrist_m) ? 1e3 * e.wrist_m : kInf;
      }
    } else {
      errors.errors_mm.push_back(kInf);
    }
    errors.forward_deg.push_back(forward);
    errors.back_normal_deg.push_back(normal);
    errors.wrist_mm.push_back(wrist);
  }
  return errors;
}

ErrorStats errorStats(const std::vector<double>& errors_mm) {
  ErrorStats stats;
  std::vector<double> finite;
  for (double e : errors_mm) {
    if (std::isfinite(e)) finite.push_back(e);
  }
  stats.frames = static_cast<int>(errors_mm.size());
  stats.failed = stats.frames - static_cast<int>(finite.size());
  const ErrorSummary tracked = summariseErrors(finite);
  stats.mean_mm = finite.empty() ? kNaN : tracked.mean_mm;
  stats.sd_mm = finite.empty() ? kNaN : tracked.sd_mm;
  // +inf is below no bound, so the percentages over all frames count failures as misses.
  stats.percent_below = summariseErrors(errors_mm).percent_below;
  return stats;
}

ErrorStats errorStats(const RunErrors& errors) {
  ErrorStats stats = errorStats(errors.errors_mm);
  int reversed = 0, rolled = 0;
  double wrist_sum = 0.0;
  const size_t n = std::min(errors.forward_deg.size(), errors.back_normal_deg.size());
  for (size_t k = 0; k < n && k < errors.wrist_mm.size(); ++k) {
    if (std::isnan(errors.forward_deg[k]) || std::isnan(errors.back_normal_deg[k])) continue;
    ++stats.oriented_frames;
    reversed += errors.forward_deg[k] > 90.0 ? 1 : 0;
    rolled += errors.back_normal_deg[k] > 90.0 ? 1 : 0;
    wrist_sum += errors.wrist_mm[k];
  }
  if (stats.oriented_frames > 0) {
    stats.reversed_pct = 100.0 * reversed / stats.oriented_frames;
    stats.rolled_pct = 100.0 * rolled / stats.oriented_frames;
    stats.wrist_mean_mm = wrist_sum / stats.oriented_frames;
  }
  return stats;
}

// The outputs' folders, checked before the hours of rendering and tracking: a --csv in a missing
// folder failed only when the tables were written at the end, an --out-dir that is a file with
// a bare filesystem error.
static void checkBenchmarkOutputs(const BenchmarkOptions& options) {
  std::error_code error;
  const fs::file_status out_dir = fs::status(options.out_dir, error);
  if (fs::exists(out_dir) && !fs::is_directory(out_dir)) {
    throw InputError("--out-dir " + options.out_dir + " exists and is not a folder");
  }
  if (options.csv.empty()) return;
  checkOutputPath(options.csv, {}, "--csv");
  const fs::path parent = fs::path(options.csv).parent_path();
  const bool in_out_dir = fs::weakly_canonical(parent.empty() ? fs::path(".") : parent, error) ==
                          fs::weakly_canonical(options.out_dir, error);
  if (!parent.empty() && !in_out_dir && !fs::is_directory(parent, error)) {
    throw InputError("--csv " + options.csv + ": the folder " + parent.string() +
                     " does not exist");
  }
  // The benchmark replaces the files of its own folder only: a --csv elsewhere replaced whatever
  // was there (a bag, another run's tables).
  if (!in_out_dir) {
    checkOutputIsNew(options.csv, false, "--csv",
                     " exists; the benchmark replaces files only in its --out-dir (choose "
                     "another name)");
  }
}

// The names of the rig, sequences and models, checked before the hours of rendering and tracking:
// an unknown name late in --sequences or --models failed only after every run before it (the
// runs lost, the error not naming the option), an unknown --fit-sequence failed each hand's fit.
static void checkBenchmarkInputs(const BenchmarkOptions& options) {
  const std::string config = packageConfigDir(options.config_dir);
  studio::resolveRigPath(options.rig, config);
  const HandModel render_model = loadHandModel(resolveModelPath("sag", config));
  auto checkMotion = [&](const std::string& option, const std::string& sequence) {
    try {
      studio::loadMotion(studio::resolveMotionPath(sequence, config), render_model, 1);
    } catch (const InputError& error) {
      throw InputError(option + " " + sequence + ": " + error.what());
    }
  };
  for (const std::string& sequence : options.sequences) checkMotion("--sequences", sequence);
  if (options.fitted) checkMotion("--fit-sequence", options.fit_sequence);
  for (const std::string& model : options.models) {
    try {
      loadHandModel(resolveModelPath(model, config));
    } catch (const InputError& error) {
      throw InputError("--models " + model + ": " + error.what());
    }
  }
}

namespace {

// The rendered hands: the asked-for names (drawn<N> or config/hand_shapes.yaml's), or without
// --shapes all of the config's list (the rooms: its default hand).
std::vector<studio::StudioHand> benchmarkHands(const BenchmarkOptions& options,
                                               const std::string& config) {
  std::vector<std::string> names = options.shapes;
  if (names.empty() && !options.rooms.empty()) names = {"default"};
  if (names.empty()) return studio::loadHandShapes(studio::handShapesPath(config));
  std::vector<studio::StudioHand> hands;
  for (const std::string& shape : names) {
    hands.push_back(studio::resolveHandShape(shape, config));
    if (hands.back().name != shape) {
      throw InputError("--shapes: the file " + shape + " names its shape '" + hands.back().name +
                       "'; give the names of config/hand_shapes.yaml");
    }
  }
  return hands;
}

}  // namespace

BenchmarkResults runBenchmark(const BenchmarkOptions& options, std::ostream& log) {
  const auto start = std::chrono::steady_clock::now();
  BenchmarkResults results;
  checkBenchmarkOutputs(options);
  checkBenchmarkInputs(options);
  {
    // An --out-dir that cannot be made failed with a bare filesystem error, not naming the option.
    std::error_code error;
    fs::create_directories(options.out_dir, error);
    if (error) {
      throw InputError("--out-dir " + options.out_dir +
                       ": cannot create the folder: " + error.message());
    }
  }
  const std::string config = packageConfigDir(options.config_dir);
  if (!options.rooms.empty()) {
    // --fitted: each hand's model fitted in the clean studio (a user who ran calibrate_hand once)
    // brings the user's skin gate into the rooms.
    std::vector<RoomHand> room_hands;
    for (const studio::StudioHand& hand : benchmarkHands(options, config)) {
      room_hands.push_back({hand, ""});
      if (!options.fitted) continue;
      const ShapeFit fit = fitShape(options, hand, log);
      if (!fit.ok) {
        throw InputError("--rooms --fitted: the fit on the hand " + hand.name +
                         " failed: " + fit.error);
      }
      room_hands.back().fitted_model = fit.model;
    }
    results.markdown = runRoomBenchmark(options, room_hands, log);
    results.seconds = secondsSince(start);
    return results;
  }
  for (const std::string& model : options.models) results.trackers.push_back(trackerLabel(model));
  if (options.fitted) results.trackers.push_back(kFittedTracker);
  const fs::path dir(options.out_dir);
  fs::create_directories(dir / "tracks");

  const std::vector<studio::StudioHand> hands = benchmarkHands(options, config);
  for (const studio::StudioHand& hand : hands) {
    results.shapes.push_back(hand.name);
    results.shape_descriptions.push_back(hand.description);
  }
  for (const std::string& sequence : options.sequences) {
    results.sequences.push_back(fs::path(sequence).stem().string());
  }

  // Figure 6 runs on the default hand (the first one if there is no default) and the Dexter 1
  // sequences but random; those bags are kept until then.
  const std::string camera_hand =
      std::find(results.shapes.begin(), results.shapes.end(), "default") != results.shapes.end()
          ? std::string("default")
          : results.shapes.front();
  const auto& dexter = studio::builtinMotionNames();
  auto usedByCameraCounts = [&](const SequenceBag& bag) {
    return options.camera_counts && bag.shape == camera_hand && bag.name != "random" &&
           std::find(dexter.begin(), dexter.end(), bag.name) != dexter.end();
  };

  // The fitted models first: every sequence of a hand is tracked with its hand's model.
  std::map<std::string, const ShapeFit*> fit_of_shape;
  if (options.fitted) {
    for (const studio::StudioHand& hand : hands)
      results.fits.push_back(fitShape(options, hand, log));
    for (const ShapeFit& fit : results.fits) fit_of_shape[fit.shape] = &fit;
  }
  int fitted_shapes = 0;
  for (const ShapeFit& fit : results.fits) fitted_shapes += fit.ok ? 1 : 0;

  std::vector<SequenceBag> camera_bags;
  const int total_main = static_cast<int>(options.sequences.size() *
                                          (hands.size() * options.models.size() + fitted_shapes));
  int done = 0;
  for (const std::string& sequence : options.sequences) {
    for (const studio::StudioHand& hand : hands) {
      const SequenceBag bag = prepareBag(options, sequence, hand, options.frames, log);
      if (results.rig_cameras == 0) {
        BagReader reader(bag.bag, BagReaderOptions());
        results.rig_cameras = static_cast<int>(reader.cameras().size());
      }
      for (const std::string& model : options.models) {
        const std::string csv =
            (dir / "tracks" / (runStem(bag.name, bag.shape) + "_" + trackerLabel(model) + ".csv"))
                .string();
        results.runs.push_back(trackRun(options, bag, model, trackerLabel(model), {}, csv));
        log << "benchmark: [" << ++done << "/" << total_main << "] " << runLine(results.runs.back())
            << "\n"
            << std::flush;
      }
      const auto fit = fit_of_shape.find(hand.name);
      if (fit != fit_of_shape.end() && fit->second->ok) {
        const std::string csv =
            (dir / "tracks" / (runStem(bag.name, bag.shape) + "_" + kFittedTracker + ".csv"))
                .string();
        results.runs.push_back(trackRun(options, bag, fit->second->model, kFittedTracker, {}, csv));
        log << "benchmark: [" << ++done << "/" << total_main << "] " << runLine(results.runs.back())
            << "\n"
            << std::flush;
      }
      if (usedByCameraCounts(bag)) {
        camera_bags.push_back(bag);
      } else if (options.discard_bags && bag.rendered) {
        fs::remove(bag.bag);
      }
    }
  }
  if (options.camera_counts && camera_bags.empty()) {
    // None of the Dexter 1 sequences but random was asked for: the first sequence's bag.
    camera_bags.push_back(
        prepareBag(options, options.sequences.front(), hands.front(), options.frames, log));
  }

  std::map<int, int> combinations_per_count;
  if (options.camera_counts) {
    std::vector<std::vector<int>> combos;
    for (int k = 2; k <= results.rig_cameras; ++k) {
      const auto of_k = combinations(results.rig_cameras, k);
      combinations_per_count[k] = static_cast<int>(of_k.size());
      combos.insert(combos.end(), of_k.begin(), of_k.end());
    }
    std::vector<const SequenceBag*> sequences;
    for (const SequenceBag& bag : camera_bags) sequences.push_back(&bag);
    const std::string scratch = (dir / "tracks" / "camera_count_run.csv").string();
    const int total = static_cast<int>(combos.size() * sequences.size() * options.models.size());
    int run_index = 0;
    for (const auto& cameras : combos) {
      for (const SequenceBag* bag : sequences) {
        for (const std::string& model : options.models) {
          results.camera_runs.push_back(
              trackRun(options, *bag, model, trackerLabel(model), cameras, scratch));
          log << "benchmark: cameras [" << ++run_index << "/" << total << "] "
              << runLine(results.camera_runs.back()) << "\n"
              << std::flush;
        }
      }
    }
    std::error_code ignored;
    fs::remove(scratch, ignored);
    if (options.discard_bags) {
      for (const SequenceBag& bag : camera_bags) {
        if (bag.rendered) fs::remove(bag.bag, ignored);
      }
    }
  }

  results.markdown = report(options, results, combinations_per_count);
  { writeOutputFile((dir / "results.md").string(), results.markdown); }
  writeResultsCsv(options.csv.empty() ? (dir / "results.csv").string() : options.csv, results);
  if (options.camera_counts) writeCameraCsvs(dir.string(), results, combinations_per_count);
  if (options.fitted) writeFittedCsv((dir / "fitted.csv").string(), results);
  if (options.plots) writePlots(dir.string(), results, combinations_per_count);
  results.seconds = secondsSince(start);
  return results;
}

}  // namespace sag_hand_tracker
