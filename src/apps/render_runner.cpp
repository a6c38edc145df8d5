// renderStudioBag: the body of the render_bag tool (see render_studio_bag.h).
#include "sag_hand_tracker/apps/render_runner.h"

#include "sag_hand_tracker/ros/package_config.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <memory>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <cv_bridge/cv_bridge.h>
#include "sag_hand_tracker/apps/csv.h"
#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/ros/bag_input.h"
#include "sag_hand_tracker/ros/conversions.h"
#include "sag_hand_tracker/studio/hand_shapes.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/studio/renderer.h"
#include "sag_hand_tracker/studio/room.h"
#include "sag_hand_tracker/studio/sequence.h"
#include "sag_hand_tracker/util/atomic_output.h"
#include "sag_hand_tracker/util/input_limits.h"
#include "sag_hand_tracker/util/number_text.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

// --hand-scale, --palm-width, --thickness, --finger-length: the range of a shape file's factors.
constexpr double kMinSizeFactor = 0.3;
constexpr double kMaxSizeFactor = 3.0;
// --start-stamp: the last frame's stamp must still fit ros::Time's 32-bit seconds.
constexpr double kMaxStartStamp = 4.0e9;
// The largest stamp a bag holds: ros::Time's seconds are 32 bits.
constexpr double kMaxBagStamp = 4294967295.0;

using studio::StudioFrame;

// Frame stamps on an exact nanosecond grid: start + index / fps.
ros::Time frameStamp(double start_seconds, int index, double fps) {
  const auto start_ns = static_cast<std::int64_t>(std::llround(start_seconds * 1e9));
  const auto offset_ns = static_cast<std::int64_t>(std::llround(index * 1e9 / fps));
  ros::Time stamp;
  stamp.fromNSec(static_cast<std::uint64_t>(start_ns + offset_ns));
  return stamp;
}

// ---- ground-truth messages ------------------------------------------------------------------

TrackingCsvRow groundTruthRow(const StudioFrame& frame, const ros::Time& stamp) {
  TrackingCsvRow row;
  row.stamp = stamp.toSec();
  row.fingertips = frame.fingertips;
  row.parameters = frame.pose.toVector();
  row.energy = 0.0;  // ground truth has no energy
  return row;
}

// Writes to `path` (the temporary file); errors name `option_path` (--preview's file) in one line.
void writeContactSheet(const std::string& path, const std::string& option_path,
                       const std::vector<studio::StudioImage>& images,
                       const std::vector<Camera>& cameras, const StudioFrame& frame,
                       const std::string& caption) {
  const cv::Mat sheet = studio::contactSheet(
      images, cameras, frame.hand_present ? &frame.fingertips : nullptr, caption);
  cv::Mat bgr;
  cv::cvtColor(sheet, bgr, cv::COLOR_RGB2BGR);
  bool written = false;
  try {
    written = cv::imwrite(path, bgr);
  } catch (const cv::Exception& error) {
    std::string reason = error.err;  // what() spans lines (file, line, function)
    throw InputError("--preview " + option_path + ": cannot write the contact sheet: " + reason);
  }
  if (!written) throw InputError("--preview " + option_path + ": cannot write the contact sheet");
}

}  // namespace

std::string renderBagUsage() {
  return "usage: render_bag --sequence <name|motion.yaml> --out OUT.bag [options]\n"
         "Renders a synthetic studio sequence (5 calibrated cameras by default) into a bag that\n"
         "track_bag reads, with the ground truth in the bag and in a CSV.\n"
         "  --sequence S       built-in motion (adbadd fingercount fingerwave flexex1 pinch\n"
         "                     random tigergrasp raised pronation wristflex fastturn natural)\n"
         "                     or a motion file (config/motions/README.md)\n"
         "  --rig R            built-in rig name, a directory with rig.yaml, or a rig file\n"
         "                     (default dexter5)\n"
         "  --out OUT.bag      the bag to write (written only when the whole run succeeds)\n"
         "  --gt-csv FILE      ground-truth CSV (default: OUT.bag with the extension .gt.csv)\n"
         "  --fps F            frame rate, 25 (Dexter 1, default) or 60\n"
         "  --frames N         number of frames (default: the motion's duration * fps)\n"
         "  --empty-frames N   frames of the empty studio before the hand (default 10; 0 in\n"
         "                     a room without them): 0 for a hand in view from the first frame\n"
         "  --seed S           seed of the motion's random parts and the sensor noise (default 1)\n"
         "  --motion-blur N    sub-frames averaged per frame (default 1: none)\n"
         "  --exposure T       exposure time in seconds for motion blur (default 0.010)\n"
         "  --noise SIGMA      sensor noise, 8-bit levels (default 2)\n"
         "  --hand-scale S     size of the rendered hand relative to the model (default 1;\n"
         "                     multiplies the shape's scale)\n"
         "  --shape NAME|FILE  the rendered hand's proportions and skin: a name from\n"
         "                     config/hand_shapes.yaml (default, long_distal, ...) or a file in\n"
         "                     that format holding one shape (default: default)\n"
         "  --bare-forearm     a bare forearm up to the elbow region instead of the black sleeve\n"
         "                     (motions with `forearm: {bare: true}` always have one)\n"
         "  --palm-width F     factor on the knuckles' spread across the palm (default 1; on\n"
         "                     top of the shape's, like the two below)\n"
         "  --finger-length F  factor on the finger bones' lengths: one for all fingers or five\n"
         "                     (thumb,index,middle,ring,pinky) (default 1)\n"
         "  --thickness F      factor on the radii of the fingers, palm and wrist (default 1)\n"
         "  --model M          hand skeleton: sag (default) or a model file\n"
         "  --hand left|right  a left or a right hand (right; the model is mirrored if\n"
         "                     needed; track it with track_bag --hand left)\n"
         "  --preview PNG      also write a contact sheet of one frame (all views + labels)\n"
         "  --preview-frame N  the frame of the contact sheet (default: the middle one)\n"
         "  --start-stamp T    stamp of the first frame in seconds (default 1400000000)\n"
         "  --compression C    bag compression: none (default), lz4 or bz2\n"
         "  --threads N        threads rendering a frame's views (default 2, 1-16; the images\n"
         "                     do not depend on it)\n"
         "  --room R           a studio room (office, kitchen, daylight; doc/segmentation.md):\n"
         "                     photographs, props, changing light; kitchen has no frames without\n"
         "                     the hand\n"
         "  --hand-masks       also write /cam<i>/hand_mask (mono8, 255 on the tracked hand's\n"
         "                     pixels: palm, fingers, bare wrist), for foreground precision\n"
         "  --config-dir DIR   where the built-in motions, rigs and models are (default: the\n"
         "                     package's config/)\n"
         "  --overwrite        replace files already at --out, --gt-csv, --preview (default:\n"
         "                     refused before anything is rendered, and a file that appears\n"
         "                     there during the run is kept too)\n"
         "  --quiet            no progress bar\n"
         "The first 10 frames (--empty-frames) show the empty studio (for the background plate);\n"
         "ground truth is written for the frames with the hand.\n";
}

RenderBagOptions parseRenderBagArguments(const std::vector<std::string>& args) {
  RenderBagOptions options;
  rejectRepeatedOptions(args);
  // An option's value never begins with "--" (`--out --quiet` would name the bag "--quiet").
  auto value = [&](size_t* i) { return nextOptionValue(args, i); };
  auto number = [&](size_t* i) {
    const std::string flag = args[*i];
    const std::string text = value(i);
    try {
      size_t used = 0;
      const double v = std::stod(text, &used);
      if (used != text.size() || !std::isfinite(v)) throw std::invalid_argument(text);
      return v;
    } catch (const std::exception&) {
      throw UsageError(flag + " needs a number, not '" + text + "'");
    }
  };
  // Bounded before the cast: 1e99 frames, threads or sub-frames wrapped around (--threads 1e99
  // passed the "at most 16" check, --motion-blur 1e99 failed later as "at least 1").
  auto integer = [&](size_t* i, long long min, long long max = 1000000) {
    const std::string flag = args[*i];
    const double v = number(i);
    if (v != std::floor(v) || v < static_cast<double>(min)) {
      throw UsageError(flag + " needs an integer >= " + std::to_string(min));
    }
    if (v > static_cast<double>(max)) {
      throw UsageError(flag + " must be at most " + std::to_string(max));
    }
    return static_cast<long long>(v);
  };
  // A size factor, within the range of a shape file's (hand_shapes.yaml): 1e99 rendered a hand
  // whose ground-truth fingertips lay 1e98 m away.
  auto size_factor = [&](size_t* i) {
    const std::string flag = args[*i];
    const double v = number(i);
    if (!(v > 0.0)) throw UsageError(flag + " must be positive");
    if (!(v >= kMinSizeFactor && v <= kMaxSizeFactor)) {
      throw UsageError(flag + " must be within [0.3, 3], got '" + args[*i] + "'");
    }
    return v;
  };
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--sequence") {
      options.sequence = value(&i);
    } else if (a == "--rig") {
      options.rig = value(&i);
    } else if (a == "--out") {
      options.out = value(&i);
    } else if (a == "--gt-csv") {
      options.gt_csv = value(&i);
    } else if (a == "--config-dir") {
      options.config_dir = value(&i);
    } else if (a == "--model") {
      options.model = value(&i);
    } else if (a == "--hand") {
      options.hand = parseHandOption(value(&i));
    } else if (a == "--fps") {
      options.fps = number(&i);
      if (!(options.fps > 0.0 && options.fps <= 1000.0))
        throw UsageError("--fps must be in (0, 1000]");
    } else if (a == "--frames") {
      options.frames = static_cast<int>(integer(&i, 1));
    } else if (a == "--empty-frames") {
      options.empty_frames = static_cast<int>(integer(&i, 0));
    } else if (a == "--seed") {
      constexpr std::uint64_t kMaxSeed = 1ULL << 53;
      options.seed = static_cast<std::uint64_t>(integer(&i, 0, static_cast<long long>(kMaxSeed)));
      // Read as a double, 2^53 + 1 rounds to 2^53 and passes the bound: digits compare exactly.
      const std::string& text = args[i];
      const std::string digits = text.substr(std::min(text.find_first_not_of('0'), text.size()));
      if (digits.find_first_not_of("0123456789") == std::string::npos &&
          (digits.size() > 16 || (!digits.empty() && std::stoull(digits) > kMaxSeed))) {
        throw UsageError(a + " must be at most " + std::to_string(kMaxSeed));
      }
    } else if (a == "--motion-blur") {
      options.motion_blur = static_cast<int>(integer(&i, 1, 1000));
    } else if (a == "--exposure") {
      options.exposure = number(&i);
      if (options.exposure < 0.0) throw UsageError("--exposure must not be negative");
    } else if (a == "--noise") {
      options.noise = number(&i);
      if (options.noise < 0.0) throw UsageError("--noise must not be negative");
      // In 8-bit levels: 1e308 rendered images of noise alone.
      if (options.noise > 255.0) throw UsageError("--noise must be at most 255 (8-bit levels)");
    } else if (a == "--hand-scale") {
      options.hand_scale = size_factor(&i);
    } else if (a == "--shape") {
      options.shape = value(&i);
    } else if (a == "--bare-forearm") {
      options.bare_forearm = true;
    } else if (a == "--palm-width") {
      options.palm_width = size_factor(&i);
    } else if (a == "--thickness") {
      options.thickness = size_factor(&i);
    } else if (a == "--finger-length") {
      const std::string text = value(&i);
      const std::vector<std::string> items =
          parseListOption("--finger-length", text, "one factor or five, like 1.1,1,1,0.9,1");
      if (items.size() != 1 && items.size() != kNumFingers) {
        throw UsageError("--finger-length expects one factor or five, got '" + text + "'");
      }
      for (int f = 0; f < kNumFingers; ++f) {
        const std::string& item = items[items.size() == 1 ? 0 : f];
        char* end = nullptr;
        const double factor = std::strtod(item.c_str(), &end);
        if (end != item.c_str() + item.size() || !(factor > 0.0) || !std::isfinite(factor)) {
          throw UsageError("--finger-length needs positive numbers, not '" + item + "'");
        }
        if (!(factor >= kMinSizeFactor && factor <= kMaxSizeFactor)) {
          throw UsageError("--finger-length must be within [0.3, 3], got '" + item + "'");
        }
        options.finger_length[f] = factor;
      }
    } else if (a == "--preview") {
      options.preview = value(&i);
      // Refused before the rendering, not when the finished sheet cannot be written.
      if (!cv::haveImageWriter(options.preview)) {
        throw UsageError("--preview " + options.preview +
                         ": not an image file name OpenCV can write (use .png or .jpg)");
      }
    } else if (a == "--preview-frame") {
      options.preview_frame = static_cast<int>(integer(&i, 0));
    } else if (a == "--start-stamp") {
      options.start_stamp = number(&i);
      if (!(options.start_stamp > 0.0)) throw UsageError("--start-stamp must be positive");
      // ros::Time holds 32-bit seconds: later stamps failed after the rendering began.
      if (options.start_stamp > kMaxStartStamp) {
        throw UsageError(
            "--start-stamp must be at most 4000000000 (2096; a bag stamp's seconds "
            "are 32 bits)");
      }
    } else if (a == "--threads") {
      options.threads = static_cast<int>(integer(&i, 1, 16));
    } else if (a == "--compression") {
      const std::string mode = value(&i);
      if (mode == "none") {
        options.compression = BagCompression::kNone;
      } else if (mode == "lz4") {
        options.compression = BagCompression::kLz4;
      } else if (mode == "bz2") {
        options.compression = BagCompression::kBz2;
      } else {
        throw UsageError("--compression must be none, lz4 or bz2, not '" + mode + "'");
      }
    } else if (a == "--room") {
      options.room = value(&i);
      try {
        studio::builtinRoom(options.room);
      } catch (const InputError& e) {
        throw UsageError(std::string("--room: ") + e.what());  // names the known rooms
      }
    } else if (a == "--hand-masks") {
      options.hand_masks = true;
    } else if (a == "--overwrite") {
      options.overwrite = true;
    } else if (a == "--quiet") {
      options.quiet = true;
    } else if (a == "--help" || a == "-h") {
      options.help = true;
    } else {
      throw UsageError("unknown argument '" + a + "'");
    }
  }
  if (options.help) return options;
  if (options.sequence.empty()) throw UsageError("--sequence is required");
  if (options.out.empty()) throw UsageError("--out is required");
  if (options.gt_csv.empty()) {
    std::filesystem::path csv(options.out);
    csv.replace_extension(".gt.csv");
    options.gt_csv = csv.string();
  }
  return options;
}

RenderBagSummary renderStudioBag(const RenderBagOptions& options, ProgressBar* progress,
                                 const std::atomic<bool>* stop) {
  const std::string config = packageConfigDir(options.config_dir);
  const std::string model_path = resolveModelPath(options.model, config);
  const std::string rig_path = studio::resolveRigPath(options.rig, config);
  const std::string motion_path = studio::resolveMotionPath(options.sequence, config);
  // The rig is read first: its calibration files are inputs too (--out cam0.yaml --overwrite
  // replaced a rig's calibration file with the bag, as --out shape.yaml did a --shape file).
  std::vector<std::string> inputs{model_path, rig_path, motion_path,
                                  studio::handShapeFile(options.shape, config)};
  const CameraRig rig = loadCameraRig(rig_path, &inputs);
  // Before any output is opened: no output may be an input or another output.
  checkDistinctOutputs(
      {{"--out", options.out}, {"--gt-csv", options.gt_csv}, {"--preview", options.preview}});
  checkOutputPath(options.out, inputs);
  checkOutputPath(options.gt_csv, inputs, "--gt-csv");
  if (!options.preview.empty()) checkOutputPath(options.preview, inputs, "--preview");
  checkOutputIsNew(options.out, options.overwrite);
  checkOutputIsNew(options.gt_csv, options.overwrite, "--gt-csv");
  if (!options.preview.empty()) checkOutputIsNew(options.preview, options.overwrite, "--preview");
  const HandModel model = loadHandModel(model_path, options.hand);
  if (rig.cameras.empty()) throw InputError("the rig has no cameras");
  // A bag's cameras are /cam<i>/image_raw, i < 64 (the bag reader's topics): a rig camera named
  // otherwise ('left') was written on a topic that track_bag and calibrate_hand pass over, and
  // they tracked the other cameras without a word.
  for (const Camera& camera : rig.cameras) {
    if (!isBagCameraName(camera.name)) {
      throw InputError("--rig " + options.rig + ": camera '" + camera.name +
                       "' is not named as a bag's cameras are (cam0 ... cam" +
                       std::to_string(kMaxCameras - 1) + ", their images on /cam<i>/image_raw); " +
                       "track_bag would not read its images");
    }
  }
  studio::Motion motion = studio::loadMotion(motion_path, model, options.seed);

  studio::SequenceParams params;
  params.fps = options.fps;
  params.frames = options.frames;
  params.seed = options.seed;
  params.motion_blur_samples = options.motion_blur;
  params.exposure = std::min(options.exposure, 1.0 / options.fps);
  const studio::StudioHand hand = studio::resolveHandShape(options.shape, config);
  params.shape = hand.shape;
  params.shape.scale *= options.hand_scale;
  params.surface.skin = hand.skin;
  params.surface.bare_forearm = options.bare_forearm;
  params.shape.palm_width *= options.palm_width;
  for (int f = 0; f < kNumFingers; ++f) params.shape.finger_length[f] *= options.finger_length[f];
  params.shape.thickness *= options.thickness;
  studio::RoomParams room_params;
  if (!options.room.empty()) {
    room_params = studio::builtinRoom(options.room);
    if (!room_params.hand_free_frames) params.empty_frames = 0;
  }
  if (options.empty_frames >= 0) params.empty_frames = options.empty_frames;
  const studio::StudioSequence sequence(model, std::move(motion), params);
  std::unique_ptr<studio::StudioRoom> room;
  studio::StudioSceneParams scene;
  if (!options.room.empty()) {
    room = std::make_unique<studio::StudioRoom>(room_params, sequence.shapedModel(), config);
    scene = room->scene(scene);
  }
  const int frames = sequence.frameCount();
  // A frame rate so low that the motion has no frame wrote a bag without images (exit status 0);
  // a last stamp past ros::Time's 32-bit seconds failed with "Time is out of dual 32-bit range".
  if (frames < 1) {
    throw InputError("--fps " + shortNumber(options.fps) +
                     " gives the motion no frame (its duration times the frame rate rounds to "
                     "0; --frames N sets the number of frames)");
  }
  const double last_stamp = options.start_stamp + (frames - 1) / options.fps;
  if (!(last_stamp <= kMaxBagStamp)) {
    throw InputError("the last frame's stamp " + shortNumber(last_stamp) + " s (--start-stamp " +
                     shortNumber(options.start_stamp) + ", " + std::to_string(frames) +
                     " frames at --fps " + shortNumber(options.fps) +
                     ") is past a bag stamp's 32-bit seconds (4294967295)");
  }
  const int preview_frame = options.preview.empty()
                                ? -1
                                : (options.preview_frame >= 0 ? options.preview_frame : frames / 2);
  if (preview_frame >= frames) {
    throw InputError("--preview-frame " + std::to_string(preview_frame) +
                     " is past the last frame " + std::to_string(frames - 1));
  }
  studio::SensorParams sensor;
  sensor.noise_sigma = options.noise;

  const auto setup_start = std::chrono::steady_clock::now();
  studio::StudioRenderer renderer(rig.cameras, scene, sensor);
  renderer.setRenderThreads(options.threads);
  const double setup_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - setup_start).count();

  const std::vector<std::string> names = model.parameterNames();
  // Every output is written next to its path and renamed there only when all succeeded: a
  // failure half way leaves no partial bag, CSV or preview, and the old files untouched.
  // Without --overwrite the commits replace nothing, not even a file created during the render.
  AtomicOutputFile bag_file(options.out, options.overwrite, "--out");
  AtomicOutputFile csv_file(options.gt_csv, options.overwrite, "--gt-csv");
  std::unique_ptr<AtomicOutputFile> preview_file;
  if (!options.preview.empty()) {
    preview_file =
        std::make_unique<AtomicOutputFile>(options.preview, options.overwrite, "--preview");
  }
  BagWriter bag(bag_file.tempPath(), options.compression);
  TrackingCsvWriter csv(csv_file.tempPath(), names);
  bag.writeStaticTransforms(rig, frameStamp(options.start_stamp, 0, options.fps));

  double render_seconds = 0.0;
  const auto loop_start = std::chrono::steady_clock::now();
  for (int k = 0; k < frames; ++k) {
    if (stop != nullptr && stop->load()) throw Interrupted();
    const ros::Time stamp = frameStamp(options.start_stamp, k, options.fps);
    const StudioFrame frame = sequence.frame(k);
    const auto render_start = std::chrono::steady_clock::now();
    auto subframes = sequence.surfaces(k);
    double light_gain = 1.0;
    if (room) {
      room->addProps(&subframes, frame.time);
      light_gain = room->lightGain(frame.time);
    }
    const auto images = renderer.render(subframes, sequence.noiseSeed(k), light_gain);
    render_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - render_start).count();
    for (size_t c = 0; c < images.size(); ++c) {
      bag.writeCameraImage(rig.cameras[c], images[c].rgb, stamp);
      if (options.hand_masks) {
        cv::Mat mask(images[c].labels.size(), CV_8UC1);
        for (size_t i = 0; i < mask.total(); ++i) {
          mask.data[i] = studio::isTrackedHandLabel(images[c].labels.data[i]) ? 255 : 0;
        }
        std_msgs::Header header;
        header.stamp = stamp;
        header.frame_id = rig.cameras[c].name + "_optical_frame";
        bag.write("/" + rig.cameras[c].name + "/hand_mask", stamp,
                  *cv_bridge::CvImage(header, "mono8", mask).toImageMsg());
      }
    }
    if (frame.hand_present) {
      std_msgs::Header header;
      header.stamp = stamp;
      header.frame_id = rig.root_frame;
      bag.write("/ground_truth/joint_states", stamp, toJointStateMsg(names, frame.pose, header));
      bag.write("/ground_truth/fingertips", stamp, toFingertipsMsg(frame.fingertips, header));
      csv.write(groundTruthRow(frame, stamp));
    }
    if (k == preview_frame) {
      writeContactSheet(preview_file->tempPath(), options.preview, images, rig.cameras, frame,
                        sequence.motion().name + " / " + hand.name + " frame " + std::to_string(k));
    }
    if (progress) {
      progress->update(static_cast<double>(k + 1) / frames,
                       "frame " + std::to_string(k + 1) + "/" + std::to_string(frames));
    }
  }
  csv.close();
  bag.close();
  bag_file.commit();
  csv_file.commit();
  if (preview_file) preview_file->commit();
  const double total_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - loop_start).count();
  if (progress) progress->finish("frame " + std::to_string(frames) + "/" + std::to_string(frames));

  RenderBagSummary summary;
  summary.sequence = sequence.motion().name;
  summary.shape = hand.name;
  summary.bare_forearm = sequence.params().surface.bare_forearm;
  summary.bag = options.out;
  summary.gt_csv = options.gt_csv;
  summary.preview = options.preview;
  summary.frames = frames;
  summary.empty_frames = params.empty_frames;
  summary.gt_rows = csv.rows();
  summary.cameras = static_cast<int>(rig.cameras.size());
  summary.fps = options.fps;
  summary.seed = options.seed;
  summary.render_seconds = render_seconds;
  summary.total_seconds = total_seconds;
  summary.setup_seconds = setup_seconds;
  return summary;
}

std::string formatRenderBagSummary(const RenderBagSummary& s) {
  std::ostringstream summary;
  summary << std::fixed << std::setprecision(1) << "render_bag: " << s.sequence << " on the hand '"
          << s.shape << "'" << (s.bare_forearm ? " (bare forearm)" : "") << ": " << s.frames
          << " frames (" << s.empty_frames << " without the hand) x " << s.cameras << " cameras at "
          << s.fps << " fps, seed " << s.seed << "\n  rendering "
          << s.frames / std::max(s.render_seconds, 1e-9) << " frames/s ("
          << 1000.0 * s.render_seconds / std::max(s.frames, 1) << " ms per frame of " << s.cameras
          << " images), with the bag and CSV " << s.frames / std::max(s.total_seconds, 1e-9)
          << " frames/s; studio set-up " << s.setup_seconds << " s\n  bag: " << s.bag
          << "\n  ground truth: " << s.gt_csv << " (" << s.gt_rows << " rows)\n";
  if (!s.preview.empty()) summary << "  contact sheet: " << s.preview << "\n";
  return summary.str();
}

}  // namespace sag_hand_tracker
