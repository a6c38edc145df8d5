#include "sag_hand_tracker/apps/track_runner.h"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <set>
#include <sstream>

#include "sag_hand_tracker/apps/plot.h"
#include "sag_hand_tracker/apps/tracking_overlay.h"
#include "sag_hand_tracker/camera/camera.h"

#include "sag_hand_tracker/model/pose.h"
#include "sag_hand_tracker/optimization/optimizer.h"
#include "sag_hand_tracker/ros/package_config.h"
#include "sag_hand_tracker/tracking/handedness.h"
#include "sag_hand_tracker/util/atomic_output.h"
#include "sag_hand_tracker/util/number_text.h"
#include "sag_hand_tracker/util/timing.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

std::vector<int> parseCameraList(const std::string& text) {
  std::vector<int> cameras;
  std::set<int> seen;
  for (const std::string& item : parseListOption("--cameras", text, "camera numbers like 0,2,4")) {
    const int id = parseIntOption("--cameras", item, 0);
    if (!seen.insert(id).second) {
      throw UsageError("--cameras lists camera " + std::to_string(id) + " twice");
    }
    cameras.push_back(id);
  }
  return cameras;
}

std::string formatSeconds(double seconds) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.2f s", seconds);
  return buffer;
}

std::string formatMillis(double seconds, int frames) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.2f ms", frames > 0 ? 1e3 * seconds / frames : 0.0);
  return buffer;
}

}  // namespace

std::string trackBagUsage() {
  return R"(Usage: track_bag --bag IN.bag --out OUT.csv [options]

Tracks the hand in a bag of calibrated cameras (/cam<i>/image_raw rgb8|bgr8, /cam<i>/camera_info,
/tf_static) without a ROS master, as fast as the CPU allows, and writes one CSV row per tracked
frame with a pose: stamp, the 5 fingertips (x,y,z in metres in the root frame), the 26 pose
parameters, the energy and the status (started, tracked, or lost: a pose the tracker rejected).
Nothing tracked is an error (exit status 1) and writes no CSV; --out is never an input, a file
already at --out is refused unless --overwrite, and a failed run leaves it untouched. Interrupted
(Ctrl-C, SIGTERM; exit status 130), it writes the rows so far only where no file was at --out.

Options:
  --bag FILE               input bag (required)
  --out FILE               output CSV (required)
  --model sag|sog|FILE     hand model: the SAG model, the SoG baseline, or a model YAML (sag)
  --hand left|right|auto   handedness; the model is mirrored if needed (right); auto: the first
                           second with the hand is tracked as both, the images decide
  --iterations N           optimiser iterations per frame (20)
  --step-control rprop|fixed  optimiser step control (rprop)
  --cameras 0,2,4          track with these cameras only (all)
  --background-frames N    first N frames show no hand: learn the background plates (10);
                           0 = no plate, a skin-colour gate instead (without this option, a
                           bag of no more than 10 frames per camera is tracked as with 0)
  --root-frame FRAME       express the output in this tf frame (the root of the bag's tf tree)
  --stamp-tolerance S      images of different cameras whose stamps differ by at most S seconds
                           are one set (0.005; 0: identical stamps only)
  --room-cues              the room cues: region of interest around the tracked hand, the
                           multi-view check before the start (a still scene: each place the
                           views agree on tried) and its re-check (doc/segmentation.md; the live
                           graph's room_cues); on by default with --background-frames 0
  --no-room-cues           the skin gate or the plate alone
  --fixed-colours          keep the model's colours (default: learnt while tracking, palm
                           Gaussians each, fingers together; the live graph's colour_adaptation)
  --generic-skin-gate      without a plate, the generic skin-colour gate even when the model's
                           colours are the user's (default: a model from calibrate_hand gives
                           the gate around its colours, which drops wood and cardboard)
  --overlay-dir DIR        also draw the tracked model over the images: DIR/frame_<n>.png for
                           every --overlay-every-th frame after the background, each start and
                           the first frame of each lost stretch (the foreground bright, the rest
                           dimmed; yellow ellipses, green fingertips). DIR must be new or empty
  --overlay-every N        with --overlay-dir: every N-th frame (25)
  --overwrite              replace a file already at --out (default: refused before the bag is
                           read, and a file that appears there during the run is kept too)
  --quiet                  no progress bar
  --help                   this text
)";
}

TrackBagOptions parseTrackBagArguments(const std::vector<std::string>& args) {
  TrackBagOptions options;
  rejectRepeatedOptions(args);
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    auto value = [&]() -> const std::string& { return nextOptionValue(args, &i); };
    if (parseBagToolOption(args, &i, &options)) continue;
    if (arg == "--iterations") {
      options.iterations = parseIntOption(arg, value(), 1);
    } else if (arg == "--step-control") {
      options.step_control = value();
      if (options.step_control != "rprop" && options.step_control != "fixed") {
        throw UsageError("--step-control expects rprop or fixed, got '" + options.step_control +
                         "'");
      }
    } else if (arg == "--cameras") {
      options.cameras = parseCameraList(value());
    } else if (arg == "--root-frame") {
      options.root_frame = value();
    } else if (arg == "--stamp-tolerance") {
      options.stamp_tolerance = parseDoubleOption(arg, value(), 0.0, 1.0);
    } else if (arg == "--room-cues") {
      options.room_cues = true;
    } else if (arg == "--no-room-cues") {
      options.room_cues = false;
    } else if (arg == "--fixed-colours") {
      options.fixed_colours = true;
    } else if (arg == "--generic-skin-gate") {
      options.generic_skin_gate = true;
    } else if (arg == "--overlay-dir") {
      options.overlay_dir = value();
    } else if (arg == "--overlay-every") {
      options.overlay_every = parseIntOption(arg, value(), 1);
    } else if (arg == "--overwrite") {
      options.overwrite = true;
    } else {
      throw UsageError("unknown argument '" + arg + "'");
    }
  }
  requireBagAndOut(options);
  if (options.overlay_dir.empty() &&
      std::find(args.begin(), args.end(), "--overlay-every") != args.end()) {
    throw UsageError("--overlay-every needs --overlay-dir");
  }
  // Values never begin with "--" (nextOptionValue), so this is the option itself.
  options.background_frames_given =
      std::find(args.begin(), args.end(), "--background-frames") != args.end();
  return options;
}

double TrackBagSummary::pipelineFps() const {
  const int frames_after_background = frames - background_frames;
  if (frames_after_background <= 0 || pipeline_seconds <= 0.0) return 0.0;
  return frames_after_background / pipeline_seconds;
}

std::string formatSummary(const TrackBagSummary& summary) {
  std::ostringstream out;
  std::string names;
  for (const std::string& name : summary.cameras) names += (names.empty() ? "" : " ") + name;
  const int after_background = summary.frames - summary.background_frames;
  char fps[32];
  std::snprintf(fps, sizeof(fps), "%.1f", summary.pipelineFps());

  out << "track_bag: " << summary.bag << (summary.interrupted ? " (interrupted)" : "") << "\n";
  out << "  frames:    " << summary.frames << " (" << summary.background_frames << " background, "
      << summary.tracked_frames << " tracked, " << summary.lost_frames << " lost, "
      << summary.waiting_frames << " without a hand pose)";
  if (summary.incomplete_sets > 0) {
    out << ", " << summary.incomplete_sets << " with a camera missing";
  }
  if (summary.dropped_images > 0) out << ", " << summary.dropped_images << " images dropped";
  out << "\n";
  out << "  cameras:   " << summary.cameras.size() << " (" << names << ")\n";
  if (!summary.handedness.empty()) out << "  hand:      " << summary.handedness << "\n";
  if (!summary.background_note.empty()) out << "  note:      " << summary.background_note << "\n";
  if (!summary.skin_gate.empty()) out << "  skin gate: " << summary.skin_gate << "\n";
  if (summary.model_size != 1.0) {
    char size[32];
    std::snprintf(size, sizeof(size), "%.3f", summary.model_size);
    out << "  model:     scaled by " << size
        << " to the hand's size in the images (the size it ended with)\n";
  }
  out << "  speed:     " << fps << " frames/s (segmentation + optimisation over "
      << after_background << " frames, decode excluded); per frame: segmentation "
      << formatMillis(summary.segmentation_seconds, after_background) << ", optimisation "
      << formatMillis(summary.tracking_seconds, after_background) << "\n";
  out << "  excluded:  decode " << formatSeconds(summary.decode_seconds) << " ("
      << formatMillis(summary.decode_seconds, summary.frames) << " per frame), background "
      << formatSeconds(summary.background_seconds) << "\n";
  out << "  track:     lost in " << summary.lost_frames << " frames, restarted in "
      << summary.restarted_frames << " frames\n";
  for (const std::string& line : stampWarnings(summary.reading, "--stamp-tolerance")) {
    out << "  warning:   " << line << "\n";
  }
  if (summary.reading.tolerated_stamps > 0) {
    out << "  stamps:    " << summary.reading.tolerated_stamps
        << " images joined a set of another camera's stamp, up to "
        << formatMillis(summary.reading.largest_stamp_difference, 1)
        << " apart (the cameras are not stamped together; --stamp-tolerance)\n";
  }
  if (!summary.overlay_dir.empty()) {
    out << "  overlays:  " << summary.overlays_written << " pictures in " << summary.overlay_dir
        << "\n";
  }
  if (summary.csv_written) {
    out << "  output:    " << summary.tracked_frames + summary.lost_rows << " rows ("
        << summary.tracked_frames << " tracked or started, " << summary.lost_rows << " lost) in "
        << summary.csv << "\n";
  } else if (summary.interrupted && summary.out_existed) {
    out << "  output:    none (interrupted; the existing " << summary.csv
        << " was left as it was)\n";
  } else if (summary.interrupted) {
    out << "  output:    none (interrupted before a row was written)\n";
  } else {
    out << "  output:    none (no frame was tracked; " << summary.csv << " not written)\n";
  }
  return out.str();
}

bool commitsTrackCsv(const TrackBagSummary& summary, std::size_t rows) {
  if (summary.interrupted) return rows > 0 && !summary.out_existed;
  return summary.tracked_frames > 0;
}

std::string csvStatus(TrackStatus status) {
  switch (status) {
    case TrackStatus::kStarted:
      return "started";
    case TrackStatus::kLost:
      return "lost";
    case TrackStatus::kTracking:
      return "tracked";
    case TrackStatus::kWaiting:
      break;
  }
  return "waiting";
}

TrackingCsvRow toCsvRow(const FrameResult& result) {
  TrackingCsvRow row;
  row.stamp = result.stamp;
  row.fingertips = result.fingertips;
  row.parameters = result.pose.toVector();
  row.energy = result.energy.total;
  row.status = csvStatus(result.status);
  return row;
}

TrackBagSummary runTrackBag(BagReader& reader, const TrackFrameFunction& track,
                            TrackingCsvWriter& csv, ProgressBar* progress,
                            const std::atomic<bool>* stop, const TrackedFrameObserver& observe) {
  TrackBagSummary summary;
  summary.bag = reader.path();
  summary.csv = csv.path();
  for (const Camera& camera : reader.cameras()) summary.cameras.push_back(camera.name);

  FrameSet set;
  while (reader.next(&set)) {
    if (stop && stop->load()) {
      summary.interrupted = true;
      break;
    }
    const auto start = std::chrono::steady_clock::now();
    const ProcessedFrame processed = track(set);
    const double seconds = secondsSince(start);
    ++summary.frames;
    if (processed.background) {
      ++summary.background_frames;
      summary.background_seconds += seconds;
    } else {
      summary.pipeline_seconds += seconds;
      summary.segmentation_seconds += processed.segmentation_seconds;
      summary.tracking_seconds += processed.tracking_seconds;
      summary.image_gaussians += processed.image_gaussians;
      const FrameResult& result = processed.result;
      // A lost frame's pose is written with its status, never counted as tracked. A lost frame
      // without a pose (after a clock jump back) has no row: the rows are counted as written.
      if (result.has_pose) {
        csv.write(toCsvRow(result));
        if (result.status == TrackStatus::kLost) ++summary.lost_rows;
      }
      if (result.status == TrackStatus::kLost) {
        ++summary.lost_frames;
      } else if (result.has_pose) {
        ++summary.tracked_frames;
      } else {
        ++summary.waiting_frames;
      }
      if (result.restarted) ++summary.restarted_frames;
    }
    if (observe) observe(set, processed);
    if (progress) {
      std::string status = "frame " + std::to_string(summary.frames) + ", " +
                           std::to_string(set.images.size()) +
                           (set.images.size() == 1 ? " camera, " : " cameras, ");
      status += processed.background ? "background" : toString(processed.result.status);
      progress->update(reader.progress(), status);
    }
  }
  const BagReaderStatistics& stats = reader.statistics();
  summary.decode_seconds = stats.decode_seconds;
  summary.incomplete_sets = static_cast<int>(stats.incomplete_sets);
  summary.dropped_images = static_cast<int>(stats.dropped_images);
  summary.reading = stats;
  if (progress) {
    progress->finish(std::to_string(summary.frames) + " frames" +
                     (summary.interrupted ? " (interrupted)" : ""));
  }
  csv.close();
  summary.csv_written = true;
  return summary;
}

std::string trackBagModelPath(const std::string& name_or_path, const std::string& config_dir) {
  if (name_or_path != "sag" && name_or_path != "sog") return name_or_path;
  return resolveModelPath(name_or_path, packageConfigDir(config_dir));
}

PipelineParams trackBagPipelineParams(const TrackBagOptions& options) {
  PipelineParams params;
  params.tracker.optimizer.iterations = options.iterations;
  params.tracker.optimizer.step_control = parseStepControl(options.step_control);
  params.background_frames = options.background_frames;
  params.segmentation.room.enabled = options.room_cues.value_or(options.background_frames == 0);
  params.tracker.colour_adaptation.enabled = !options.fixed_colours;
  params.skin_gate_from_model = !options.generic_skin_gate;
  return params;
}

// =================================================================================================
// THE TRACKING CALL. One synchronized set of camera images in, one result out: the first
// background_frames sets train each camera's background plate; every later set is segmented per
// camera (image -> foreground image SoG, undistorted) and handed to HandTracker::update (automatic
// start, warm-started optimisation, restart when lost). Everything else here is input and output.
// =================================================================================================
TrackBagSummary trackBag(const TrackBagOptions& options, ProgressBar* progress,
                         const std::atomic<bool>* stop) {
  const std::string model_path = trackBagModelPath(options.model, options.config_dir);
  // Before anything is opened: --out must not be an input (the bag, the model file).
  checkOutputPath(options.out, {options.bag, model_path});
  checkOutputIsNew(options.out, options.overwrite);
  if (!options.overlay_dir.empty()) prepareOverlayDir(options.overlay_dir, "--overlay-dir");
  HandModel model = loadHandModel(model_path, options.hand);

  BagReaderOptions reader_options;
  reader_options.cameras = options.cameras;
  reader_options.root_frame = options.root_frame;
  reader_options.stamp_tolerance = options.stamp_tolerance;
  BagReader reader(options.bag, reader_options);
  // A plate needs frames without the hand before the ones with it; a bag no longer than the
  // default background frames (a pair of photographs, a second held still) would be all plate.
  std::string background_note;
  TrackBagOptions effective = options;
  const std::uint64_t most_images = reader.statistics().most_camera_images;
  if (!options.background_frames_given && options.background_frames > 0 &&
      most_images <= static_cast<std::uint64_t>(options.background_frames)) {
    effective.background_frames = 0;
    background_note = "the bag has " + std::to_string(most_images) + " image" +
                      (most_images == 1 ? "" : "s") + " per camera at most, not more than the " +
                      std::to_string(options.background_frames) +
                      " background frames a plate needs: every frame tracked without one (the "
                      "skin gate, as with --background-frames 0)";
  }
  const PipelineParams params = trackBagPipelineParams(effective);

  if (static_cast<int>(reader.cameras().size()) < params.tracker.min_cameras_for_start) {
    // Named here, where the bag is known: which cameras have images (or were chosen).
    throw InputError(
        options.bag + ": images of " + std::to_string(reader.cameras().size()) + " camera (" +
        cameraNames(reader.cameras()) + (options.cameras.empty() ? "" : ", chosen by --cameras") +
        "); the tracker starts from at least " +
        std::to_string(params.tracker.min_cameras_for_start) + " cameras that see the hand");
  }
  std::string handedness;
  if (options.hand_auto) {
    // A first pass over the bag's first sets decides; the track below starts from the first set
    // again, so it is the track that --hand with the chosen side gives.
    BagReader probe(options.bag, reader_options);
    if (progress) progress->update(0.0, "which hand: tracking the first second as both");
    const HandednessDecision decision = decideHandedness(
        model, probe.cameras(), params,
        [&probe, stop](FrameSet* set) { return !(stop && *stop) && probe.next(set); });
    if (decision.hand != model.handedness) model = mirrorHandModel(model);
    handedness = handednessText(decision);
  }
  TrackingPipeline pipeline(model, reader.cameras(), params);

  // The CSV is written next to --out and renamed over it only when frames were tracked: a run
  // that fails half way, or tracks nothing, leaves no CSV and whatever was at --out untouched.
  std::error_code ignored;
  const bool out_existed = std::filesystem::exists(options.out, ignored);
  // Without --overwrite the commit replaces nothing: a file created at --out during the run stays.
  AtomicOutputFile out(options.out, options.overwrite, "--out");
  TrackingCsvWriter csv(out.tempPath(), model.parameterNames(), /*status_column=*/true);
  OverlaySchedule overlay_schedule(options.overlay_every);
  long set_number = 0;
  int overlays_written = 0;
  TrackedFrameObserver overlay;
  if (!options.overlay_dir.empty()) {
    overlay = [&](const FrameSet& set, const ProcessedFrame& processed) {
      ++set_number;
      if (processed.background || !overlay_schedule.wants(processed.result)) return;
      std::vector<cv::Mat> foregrounds;
      for (size_t c = 0; c < reader.cameras().size(); ++c) {
        foregrounds.push_back(pipeline.foregroundMask(static_cast<int>(c)));
      }
      const cv::Mat sheet =
          trackingOverlaySheet(set, reader.cameras(), foregrounds, pipeline.tracker().model(),
                               processed.result, set_number);
      cv::Mat bgr;
      cv::cvtColor(sheet, bgr, cv::COLOR_RGB2BGR);
      writePng(overlayPath(options.overlay_dir, set_number), bgr, /*overwrite=*/false);
      ++overlays_written;
    };
  }
  TrackBagSummary summary = runTrackBag(
      reader, [&pipeline](const FrameSet& set) { return pipeline.process(set); }, csv, progress,
      stop, overlay);
  summary.overlays_written = overlays_written;
  summary.overlay_dir = options.overlay_dir;
  summary.csv = options.out;
  summary.out_existed = out_existed;
  summary.handedness = handedness;
  summary.background_note = background_note;
  summary.model_size = pipeline.tracker().sizeFactor();
  if (params.background_frames == 0) {
    const SkinParams& gate = pipeline.params().segmentation.skin;
    std::string source;
    if (pipeline.skinGateFromModel()) {
      source = "the model's colours (the user's skin): ";
    } else if (!pipeline.skinGateProblem().empty()) {
      source = "generic, not the model's (" + pipeline.skinGateProblem() + "): ";
    } else if (model.colours_fitted) {
      source = "generic (--generic-skin-gate): ";
    } else {
      source = "generic (the model's colours are not the user's; calibrate_hand gives them): ";
    }
    summary.skin_gate = source + skinGateText(gate);
    const double start_weight = pipeline.tracker().params().start_model_area_weight;
    if (start_weight > 0.0) {
      summary.skin_gate += "; starts scored with the model's area charged (lambda " +
                           shortNumber(start_weight) + ", doc/segmentation.md \"Session 33\")";
    }
  }
  summary.csv_written = commitsTrackCsv(summary, csv.rows());
  if (summary.csv_written) out.commit();
  return summary;
}

}  // namespace sag_hand_tracker
