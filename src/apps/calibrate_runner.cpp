// calibrateHand: the body of the calibrate_hand tool (see calibrate_hand_runner.h).
#include "sag_hand_tracker/apps/calibrate_runner.h"

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "sag_hand_tracker/apps/track_runner.h"
#include "sag_hand_tracker/apps/tracking_overlay.h"
#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/ros/bag_input.h"
#include "sag_hand_tracker/ros/package_config.h"
#include "sag_hand_tracker/studio/hand_shapes.h"
#include "sag_hand_tracker/studio/hand_surface.h"
#include "sag_hand_tracker/tracking/tracking_pipeline.h"
#include "sag_hand_tracker/util/atomic_output.h"
#include "sag_hand_tracker/util/number_text.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

// calibrate_hand never replaces a file (no --overwrite).
void refuseExisting(const std::string& path, const std::string& option) {
  checkOutputIsNew(path, /*overwrite=*/false, option,
                   ": the file exists; calibrate_hand does not overwrite files (remove it or "
                   "choose another name)");
}

// The output's temporary file (AtomicOutputFile) must be creatable: checked by creating and
// removing one before the recording is tracked and fitted, not when the fitted model is written
// at the end (a missing or read-only folder, a name too long, "cannot write the file").
void requireWritable(const std::string& path, const std::string& option) {
  const AtomicOutputFile probe(path, /*overwrite=*/false, option);
}

// The contact sheet: rows of frames (up to 4 of the fit's frames), one column per camera, the
// fitted model drawn over each image. Reads the bag a second time for the images.
cv::Mat fittedContactSheet(const CalibrateHandOptions& options,
                           const BagReaderOptions& reader_options,
                           const std::vector<CalibrationFrame>& frames, const HandFitResult& fit) {
  std::vector<int> rows;  // positions in fit.frame_indices
  const int used = static_cast<int>(fit.frame_indices.size());
  for (int i : selectCalibrationFrames(used, 4)) rows.push_back(i);
  BagReader reader(options.bag, reader_options);
  const std::vector<Camera>& cameras = reader.cameras();
  const int tile_w = cameras.front().width, tile_h = cameras.front().height;
  cv::Mat sheet(static_cast<int>(rows.size()) * tile_h, static_cast<int>(cameras.size()) * tile_w,
                CV_8UC3, cv::Scalar::all(255));
  FrameSet set;
  size_t next_row = 0;
  while (next_row < rows.size() && reader.next(&set)) {
    const int row = rows[next_row];
    const CalibrationFrame& frame = frames[fit.frame_indices[row]];
    if (std::abs(set.stamp() - frame.stamp) > 1e-6) continue;
    for (const CameraImage& image : set.images) {
      pasteSheetTile(
          drawModelOverlay(image.rgb, cameras[image.camera], fit.model, fit.poses[row]),
          cameras[image.camera].name + " t=" + fixedNumber(frame.stamp - frames.front().stamp, 2) +
              " s",
          cv::Rect(image.camera * tile_w, static_cast<int>(next_row) * tile_h, tile_w, tile_h),
          &sheet);
    }
    ++next_row;
  }
  return sheet;
}

}  // namespace

std::string calibrateHandUsage() {
  return R"(Usage: calibrate_hand --bag IN.bag --out my_hand.yaml [options]

Fits the hand model to the hand in a recording of the calibration routine (3-5 s: open hand with
the fingers spread, the palm turned up to the cameras and back, a fist; doc/calibration.md), or
in any recording of at least 2 s with the hand open in some frames (the fit then uses those):
overall size, palm width, finger length, bone lengths, the Gaussians' widths and colours. Writes
an ordinary model file for track_bag --model, the benchmark and the tracker's 'model' parameter.
The bag is what track_bag reads (/cam<i>/image_raw, /cam<i>/camera_info, /tf_static); its first
frames must show the scene without the hand.

Options:
  --bag FILE               the recording (required)
  --out FILE               the fitted model to write (required; an existing file is not replaced)
  --model sag|FILE         the start model (sag)
  --hand left|right        handedness; the start model is mirrored if needed (right)
  --background-frames N    first N frames show no hand: learn the background plates (10)
  --contact-sheet PNG      also write the fitted model drawn over the images of 4 frames
  --max-frames N           frames of the recording the fit uses (16)
  --rounds N               sweeps of the greedy search (2)
  --require-routine        refuse a recording without every pose of the routine (default: fit
                           what it shows, on its open-hand frames, and say what was missing)
  --truth-shape NAME|FILE  a studio hand (config/hand_shapes.yaml, or a shape file) shown in
                           the bag: also print the fitted bones' errors against its true skeleton
  --truth-model sag|FILE   the skeleton that hand was rendered from (render_bag's --model; sag),
                           whatever the start model is
  --quiet                  no progress bar
  --help                   this text
)";
}

CalibrateHandOptions parseCalibrateHandArguments(const std::vector<std::string>& args) {
  CalibrateHandOptions options;
  rejectRepeatedOptions(args);
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    auto value = [&]() -> const std::string& { return nextOptionValue(args, &i); };
    if (parseBagToolOption(args, &i, &options)) continue;
    if (arg == "--contact-sheet") {
      options.contact_sheet = value();
    } else if (arg == "--max-frames") {
      options.max_frames = parseIntOption(arg, value(), 1);
    } else if (arg == "--rounds") {
      options.rounds = parseIntOption(arg, value(), 1);
    } else if (arg == "--config-dir") {
      options.config_dir = value();
    } else if (arg == "--require-routine") {
      options.require_routine = true;
    } else if (arg == "--truth-shape") {
      options.truth_shape = value();
    } else if (arg == "--truth-model") {
      options.truth_model = value();
    } else {
      throw UsageError("unknown argument '" + arg + "'");
    }
  }
  requireBagAndOut(options);
  return options;
}

CalibrateHandSummary calibrateHand(const CalibrateHandOptions& options, ProgressBar* progress,
                                   const std::atomic<bool>* stop) {
  const auto start_time = std::chrono::steady_clock::now();
  refuseExisting(options.out, "--out");
  requireWritable(options.out, "--out");
  if (!options.contact_sheet.empty()) {
    refuseExisting(options.contact_sheet, "--contact-sheet");
    requireWritable(options.contact_sheet, "--contact-sheet");
    // Renamed after the model, the sheet would replace it: the fitted model lost, exit status 0.
    std::error_code error;
    if (std::filesystem::weakly_canonical(options.contact_sheet, error) ==
        std::filesystem::weakly_canonical(options.out, error)) {
      throw InputError("--contact-sheet " + options.contact_sheet +
                       " is the --out file; give the contact sheet a name of its own");
    }
  }

  CalibrateHandSummary summary;
  summary.bag = options.bag;
  summary.start_model =
      loadHandModel(trackBagModelPath(options.model, options.config_dir), options.hand);
  const HandModel& start = summary.start_model;
  // The true skeleton, resolved before the long work so that a wrong name fails at once: the
  // studio hand shaped from the skeleton it was rendered from (render_bag's --model), which is
  // not the start model when the fit starts from a fitted one.
  HandModel truth;
  if (!options.truth_shape.empty()) {
    truth = studio::shapeHandModel(
        loadHandModel(trackBagModelPath(options.truth_model, options.config_dir), options.hand),
        studio::resolveHandShape(options.truth_shape, packageConfigDir(options.config_dir)).shape);
  }

  BagReaderOptions reader_options;
  BagReader reader(options.bag, reader_options);
  summary.cameras = static_cast<int>(reader.cameras().size());
  if (summary.cameras < 2) {
    throw InputError(options.bag + ": the recording has " + std::to_string(summary.cameras) +
                     " camera; calibrate_hand needs at least 2 views of the hand");
  }

  // 1. Track the routine with the start model, as track_bag does, keeping what the tracker saw.
  PipelineParams pipeline_params;
  pipeline_params.background_frames = options.background_frames;
  pipeline_params.tracker = calibrationTrackerParams();
  // The start model's colours, as before the tracker learnt colours (session 8): the fit takes
  // its own from the images, at its own poses.
  pipeline_params.tracker.colour_adaptation.enabled = false;
  TrackingPipeline pipeline(start, reader.cameras(), pipeline_params);
  std::vector<CalibrationFrame> frames;
  FrameSet set;
  std::vector<CameraObservation> observations;
  RoutineRequirements requirements;
  // A clock set forward (the reader's forward_jumps) is no time in view.
  requirements.max_frame_gap = kStampJumpSeconds;
  // Frames taken as background, and of the others those with some foreground: a recording where
  // none has any shows no hand, which "the hand was never found" did not tell from a failed start.
  int background_frames = 0, foreground_frames = 0;
  while (reader.next(&set)) {
    if (stop && stop->load()) throw InputError("interrupted");
    const ProcessedFrame processed = pipeline.process(set, &observations);
    ++summary.frames;
    if (processed.background) {
      ++background_frames;
    } else if (processed.image_gaussians >= requirements.min_foreground_gaussians) {
      ++foreground_frames;
    }
    const FrameResult& result = processed.result;
    if (!processed.background && result.has_pose && result.status != TrackStatus::kLost) {
      CalibrationFrame frame;
      frame.stamp = result.stamp;
      frame.observations = observations;
      frame.pose = result.pose;
      frames.push_back(std::move(frame));
    }
    if (progress) {
      progress->update(0.3 * reader.progress(),
                       "tracking frame " + std::to_string(summary.frames) + ", " +
                           (processed.background ? "background" : toString(result.status)));
    }
  }
  summary.tracked_frames = static_cast<int>(frames.size());
  // The stamp checks of track_bag (the reader's), in the same words: images dropped for stamps
  // going backwards or repeated, clocks set forward, cameras not stamped together.
  const BagReaderStatistics& stamps = reader.statistics();
  summary.stamp_warnings = stampWarnings(stamps);
  std::string stamp_notes;
  for (const std::string& line : summary.stamp_warnings) stamp_notes += "\nwarning: " + line;
  // Sets of cameras not stamped together lack cameras, and the tracker's poses and the fit's
  // views mix moments: a camera 30 ms late gave a hand of size x0.88 with exit status 0.
  if (camerasOutOfStep(stamps, summary.frames)) {
    throw InputError(options.bag + ": " + stampFailure(stamps, summary.frames) +
                     "; calibrate_hand fits no hand from cameras that are not stamped together "
                     "(their sets lack cameras and mix moments)");
  }

  // 2. Was the routine followed?
  summary.routine = checkCalibrationRoutine(start, frames, summary.cameras, requirements);
  if (frames.empty()) {
    const std::string names = cameraNames(reader.cameras());
    const int after_background = summary.frames - background_frames;
    const std::string counts = std::to_string(after_background) + " frame" +
                               (after_background == 1 ? "" : "s") + " after the " +
                               std::to_string(background_frames) + " background frame" +
                               (background_frames == 1 ? "" : "s");
    std::string why = stampFailure(stamps, summary.frames);
    if (!why.empty()) {
      // The stamps explain it (as in track_bag): not "all 1 frames were background frames".
    } else if (after_background == 0) {
      why = "all " + std::to_string(summary.frames) +
            " frames of the recording were background frames (--background-frames " +
            std::to_string(options.background_frames) + "): none could show the hand";
    } else if (foreground_frames == 0) {
      why = "no frame had foreground: the recording shows no hand (" + counts + ", cameras " +
            names + ")";
    } else {
      why = "the hand was never found in the images (" + std::to_string(foreground_frames) +
            " of the " + counts + " had foreground, cameras " + names + ")";
    }
    for (std::string& item : summary.routine.missing) {
      if (item.rfind("no frame with the hand", 0) == 0) item = "no frame with the hand: " + why;
    }
  }
  // Without some of the routine's poses (the first seconds of any sequence) the fit still runs,
  // on the open-hand frames, and the summary says what was missing; --require-routine refuses.
  if (!summary.routine.ok || (options.require_routine && !summary.routine.complete)) {
    std::string missing;
    for (const std::string& item : summary.routine.missing) missing += "\n  - " + item;
    throw InputError(options.bag +
                     ": the recording does not show the calibration routine (open hand, palm and "
                     "back turned to the cameras, a fist; doc/calibration.md):" +
                     missing + stamp_notes);
  }

  // 3. Fit, from the start model at the size the tracker ended the routine with (RoutineTracking).
  summary.start_size = pipeline.tracker().sizeFactor();
  const HandModel fit_start = scaleHandModel(start, summary.start_size, 1.0);
  HandFitParams fit_params;
  fit_params.max_frames = options.max_frames;
  fit_params.rounds = options.rounds;
  fit_params.open_hand_frames = !summary.routine.complete;
  summary.fit =
      fitHandModel(fit_start, frames, fit_params, [&](double fraction, const std::string& status) {
        if (stop && stop->load()) throw InputError("interrupted");
        if (progress) progress->update(0.3 + 0.7 * fraction, status);
      });
  std::vector<CalibrationFrame> used;
  std::vector<Pose> tracked_poses;
  for (int index : summary.fit.frame_indices) {
    used.push_back(frames[index]);
    tracked_poses.push_back(frames[index].pose);
  }
  if (!options.truth_shape.empty()) {
    summary.truth_shape = options.truth_shape;
    summary.truth_errors = compareSkeletons(summary.fit.model, truth);
  }
  summary.tips_on_foreground_before = fingertipsOnForeground(fit_start, used, tracked_poses);
  summary.tips_on_foreground_after =
      fingertipsOnForeground(summary.fit.model, used, summary.fit.poses);

  // 4. Write through temporary files (atomic_output.h); check that the model file loads back
  // before it is committed. The commits replace nothing: a file created at --out while the
  // recording was fitted stays, and the fitted model is kept under a name the error gives.
  AtomicOutputFile model_file(options.out, /*overwrite=*/false, "--out");
  {
    std::ofstream file(model_file.tempPath());
    file << formatHandModel(summary.fit.model, "Fitted by calibrate_hand from " + options.bag +
                                                   " (start model " + options.model +
                                                   ").\nFormat: README.md, 'Hand models'.");
    if (!file) throw InputError("--out " + options.out + ": cannot write the file");
  }
  try {
    loadHandModel(model_file.tempPath());
  } catch (const InputError& error) {
    throw InputError(std::string("internal error: the fitted model does not load back: ") +
                     error.what());
  }
  std::unique_ptr<AtomicOutputFile> sheet_file;
  if (!options.contact_sheet.empty()) {
    sheet_file =
        std::make_unique<AtomicOutputFile>(options.contact_sheet, false, "--contact-sheet");
    const cv::Mat sheet = fittedContactSheet(options, reader_options, frames, summary.fit);
    cv::Mat bgr;
    cv::cvtColor(sheet, bgr, cv::COLOR_RGB2BGR);
    // Encoded as PNG whatever the name ends with (imwrite goes by the extension, and a name
    // without .png would fail only now, after the fit).
    std::vector<unsigned char> png;
    bool written = false;
    try {
      written = cv::imencode(".png", bgr, png);
    } catch (const cv::Exception& error) {
      written = false;
    }
    if (written) {
      std::ofstream file(sheet_file->tempPath(), std::ios::binary);
      file.write(reinterpret_cast<const char*>(png.data()),
                 static_cast<std::streamsize>(png.size()));
      written = static_cast<bool>(file);
    }
    if (!written)
      throw InputError("--contact-sheet " + options.contact_sheet + ": cannot write the PNG");
  }
  // Committed last, after every check, the model first: it is the work worth keeping.
  model_file.commit();
  summary.out = options.out;
  if (sheet_file) {
    sheet_file->commit();
    summary.contact_sheet = options.contact_sheet;
  }
  if (progress) progress->finish("fitted");
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_time).count();
  return summary;
}

std::string formatCalibrateHandSummary(const CalibrateHandSummary& s) {
  std::ostringstream out;
  const HandFitResult& fit = s.fit;
  out << "calibrate_hand: " << s.bag << "\n";
  out << "  frames:       " << s.frames << " read, " << s.tracked_frames << " with the hand ("
      << fixedNumber(s.routine.duration, 1) << " s), " << fit.frame_indices.size()
      << " used by the fit" << (fit.open_frames_only ? " (open hand)" : "") << "; " << s.cameras
      << " cameras, " << s.routine.views << " seeing the hand\n";
  out << "  routine:      open hand " << s.routine.open_frames << ", palm to a camera "
      << s.routine.palm_frames << ", back to a camera " << s.routine.back_frames << ", fist "
      << s.routine.fist_frames << " frames\n";
  for (const std::string& line : s.stamp_warnings) out << "  warning:      " << line << "\n";
  if (!s.routine.complete) {
    out << "  warning:      the recording does not show the whole routine; fitted from what it "
           "shows:\n";
    for (const std::string& item : s.routine.missing) out << "                - " << item << "\n";
  }
  out << "  start size:   x" << fixedNumber(s.start_size, 3)
      << " (the tracker's, from the routine's open hand; the factors below are on top of it)\n";
  out << "  global shape: thickness x" << fixedNumber(fit.shape.thickness, 3) << ", size x"
      << fixedNumber(fit.shape.scale, 3) << ", palm width x" << fixedNumber(fit.shape.palm_width, 3)
      << ", finger length x" << fixedNumber(fit.shape.finger_length, 3) << "\n";
  out << "  palm length:  x" << fixedNumber(fit.shape.bone_length.at(0), 3)
      << " (wrist to the finger roots; follows the size unless fitted)\n";
  out << "  finger bones (mm, start -> fitted):\n";
  const auto chains = studio::fingerChains(s.start_model);
  for (int f = 0; f < kNumFingers; ++f) {
    out << "    " << fingerNames()[f] << ":";
    for (int b : chains[f]) {
      out << " " << fixedNumber(1e3 * s.start_model.bones[b].length, 1) << " -> "
          << fixedNumber(1e3 * fit.model.bones[b].length, 1);
      if (b != chains[f].back()) out << ",";
    }
    out << "\n";
  }
  double along_min = 1e9, along_max = 0, across_min = 1e9, across_max = 0;
  for (const Eigen::Vector3d& g : fit.shape.gaussian_scale) {
    along_min = std::min(along_min, g.x());
    along_max = std::max(along_max, g.x());
    across_min = std::min(across_min, g.tail<2>().minCoeff());
    across_max = std::max(across_max, g.tail<2>().maxCoeff());
  }
  out << "  Gaussians:    own factors beside the thickness: along the bone x"
      << fixedNumber(along_min, 2) << "..x" << fixedNumber(along_max, 2) << ", across x"
      << fixedNumber(across_min, 2) << "..x" << fixedNumber(across_max, 2)
      << "; colours sampled (palm hsv " << fixedNumber(fit.model.gaussians[0].hsv[0], 0) << ", "
      << fixedNumber(fit.model.gaussians[0].hsv[1], 2) << ", "
      << fixedNumber(fit.model.gaussians[0].hsv[2], 2) << ")\n";
  out << "  energy E:     " << fixedNumber(fit.energy_before, 4) << " -> "
      << fixedNumber(fit.energy_after, 4) << " (mean over the frames used); shape score "
      << fixedNumber(fit.score_before, 4) << " -> " << fixedNumber(fit.score_after, 4) << "; "
      << fit.accepted << " of " << fit.trials << " shape steps taken\n";
  out << "  fingertips:   on the foreground in "
      << fixedNumber(100.0 * s.tips_on_foreground_before, 1)
      << " % of the views with the start model, "
      << fixedNumber(100.0 * s.tips_on_foreground_after, 1) << " % with the fitted one\n";
  if (!s.truth_shape.empty()) {
    const SkeletonErrors& e = s.truth_errors;
    out << "  against the true skeleton of '" << s.truth_shape
        << "' (fitted / true - 1; bones palm to tip, the knuckle's distance from the wrist, the "
           "finger's length):\n";
    for (int f = 0; f < kNumFingers; ++f) {
      out << "    " << fingerNames()[f] << ": bones";
      for (double error : e.bone[f]) out << " " << fixedNumber(100.0 * error, 1) << " %";
      out << "; knuckle " << fixedNumber(100.0 * e.knuckle[f], 1) << " %, finger "
          << fixedNumber(100.0 * e.finger[f], 1) << " %\n";
    }
    out << "    worst bone " << fixedNumber(100.0 * e.worst_bone, 1) << " %, "
        << e.bonesWithin(kFitBoneTolerance) << " of " << kNumFingers * 3 << " bones within "
        << fixedNumber(100.0 * kFitBoneTolerance, 0) << " %\n";
  }
  out << "  output:       " << s.out;
  if (!s.contact_sheet.empty()) out << ", contact sheet " << s.contact_sheet;
  out << " (" << fixedNumber(s.seconds, 1) << " s)\n";
  return out.str();
}

}  // namespace sag_hand_tracker
