// track_bag end to end: a synthetic multi-camera bag written in the test (the hand model's
// Gaussians drawn as skin-coloured ellipses over a desk, after a few frames of empty desk) is
// tracked from its first frame; every bad input gets a one-line error and a non-zero exit.
#include <gtest/gtest.h>

#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/String.h>
#include <sys/wait.h>
#include "test_support/temp_files.h"

#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <set>
#include <sstream>

#include "sag_hand_tracker/apps/csv.h"
#include "sag_hand_tracker/apps/metrics.h"
#include "sag_hand_tracker/apps/render_runner.h"
#include "sag_hand_tracker/apps/track_runner.h"
#include "sag_hand_tracker/apps/tracking_overlay.h"
#include "sag_hand_tracker/ros/bag_output.h"
#include "sag_hand_tracker/ros/conversions.h"
#include "sag_hand_tracker/segmentation/background_plate.h"
#include "sag_hand_tracker/util/number_text.h"
#include "test_support/rendered_scene.h"

using namespace sag_hand_tracker;
namespace fs = std::filesystem;

namespace {

constexpr int kBackgroundFrames = 3;
constexpr int kHandFrames = 8;

ros::Time frameTime(int frame) { return ros::Time(1000, 0) + ros::Duration(0.04 * frame); }

Pose truthAt(const HandModel& model, int hand_frame) {
  Pose pose = sag_test::typicalPose(model);
  pose.translation.x() += 0.003 * hand_frame;
  pose.joints[4] += 0.03 * hand_frame;
  return pose;
}

class TrackBagTool : public sag_test::TempDirTest {
 protected:
  ToolRun trackBag(const std::string& arguments) const {
    return runTool(std::string("'") + SAG_BIN_DIR + "/track_bag' " + arguments);
  }

  std::string modelArgument() const {
    return "--model '" + sag_test::modelPath("sag") + "' --background-frames " +
           std::to_string(kBackgroundFrames);
  }

  // The desk for kBackgroundFrames, then the hand for kHandFrames, on the rendered rig; camera i
  // stamped i * `camera_skew` seconds after camera 0.
  // `tail`, when given, writes more messages after the scene.
  std::string writeSceneBag(const std::string& name, double camera_skew = 0.0,
                            const std::function<void(BagWriter*)>& tail = nullptr) const {
    const HandModel model = loadHandModel(sag_test::modelPath("sag"));
    const std::vector<Camera> cameras = sag_test::renderedRig();
    BagWriter writer(path(name));
    writer.writeStaticTransforms("world", cameras, frameTime(0));
    for (int frame = 0; frame < kBackgroundFrames + kHandFrames; ++frame) {
      for (std::size_t i = 0; i < cameras.size(); ++i) {
        const cv::Mat rgb = frame < kBackgroundFrames
                                ? sag_test::desk(cameras[i])
                                : sag_test::renderHand(
                                      model, truthAt(model, frame - kBackgroundFrames), cameras[i]);
        writer.writeCameraImage(cameras[i], rgb, frameTime(frame) + ros::Duration(camera_skew * i),
                                i % 2 ? "bgr8" : "rgb8");
      }
    }
    if (tail) tail(&writer);
    return path(name);
  }

  // Runs track_bag on `bag` and expects exit 1 and exactly "track_bag: error: <bag>: <what>".
  void expectError(const std::string& bag, const std::string& what) const {
    const ToolRun run = trackBag("--bag '" + bag + "' --out '" + path("bad.csv") + "' " +
                                 modelArgument() + " --quiet");
    EXPECT_EQ(run.status, 1) << run.err;
    EXPECT_EQ(run.err, "track_bag: error: " + bag + ": " + what + "\n");
    EXPECT_FALSE(fs::exists(path("bad.csv"))) << "no CSV for a failed run";
  }
};

}  // namespace

TEST_F(TrackBagTool, TrackBagTracksASyntheticBagFromItsFirstFrame) {
  const HandModel model = loadHandModel(sag_test::modelPath("sag"));
  writeSceneBag("scene.bag");
  const ToolRun run = trackBag("--bag '" + path("scene.bag") + "' --out '" + path("track.csv") +
                               "' " + modelArgument());
  ASSERT_EQ(run.status, 0) << run.err << run.out;
  EXPECT_NE(run.err.find("100% 11 frames"), std::string::npos) << run.err;  // progress bar
  EXPECT_NE(run.out.find("frames:    11 (3 background, 8 tracked, 0 lost, 0 without a hand pose)"),
            std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("cameras:   4 (cam0 cam1 cam2 cam3)"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("frames/s (segmentation + optimisation over 8 frames"), std::string::npos)
      << run.out;

  const TrackingCsv csv = readTrackingCsv(path("track.csv"));
  EXPECT_EQ(csv.parameter_names, model.parameterNames());
  ASSERT_EQ(csv.rows.size(), static_cast<std::size_t>(kHandFrames));
  // The status column: the first row started the track, the others followed it.
  ASSERT_TRUE(csv.has_status);
  EXPECT_EQ(csv.rows.front().status, "started");
  for (int k = 1; k < kHandFrames; ++k) EXPECT_EQ(csv.rows[k].status, "tracked") << k;
  EXPECT_NE(
      run.out.find("output:    8 rows (8 tracked or started, 0 lost) in " + path("track.csv")),
      std::string::npos)
      << run.out;
  double sum = 0.0;
  for (int k = 0; k < kHandFrames; ++k) {
    const TrackingCsvRow& row = csv.rows[k];
    EXPECT_NEAR(row.stamp, frameTime(kBackgroundFrames + k).toSec(), 1e-6);
    const auto truth = fingertips(model, truthAt(model, k));
    double error = 0.0;
    for (int f = 0; f < kNumFingers; ++f) error += (row.fingertips[f] - truth[f]).norm();
    sum += error / kNumFingers;
  }
  // The tracker's accuracy is measured elsewhere; here: the rows are poses of this hand, in the
  // bag's root frame.
  EXPECT_LT(sum / kHandFrames, 0.03)
      << "mean fingertip error " << 1000 * sum / kHandFrames << " mm";

  // A camera subset, quietly.
  const ToolRun subset = trackBag("--bag '" + path("scene.bag") + "' --out '" + path("subset.csv") +
                                  "' " + modelArgument() + " --cameras 0,2,3 --quiet");
  ASSERT_EQ(subset.status, 0) << subset.err;
  EXPECT_EQ(subset.err, "");
  EXPECT_NE(subset.out.find("cameras:   3 (cam0 cam2 cam3)"), std::string::npos) << subset.out;
}

// Without a plate, a model whose colours are the user's (calibrate_hand's) brings its own skin
// gate (PipelineParams::skin_gate_from_model); the summary says which gate segmented the images.
TEST_F(TrackBagTool, TrackBagSaysWhichSkinGateItUsed) {
  writeSceneBag("scene.bag");
  const std::string fitted = std::string(SAG_SOURCE_DIR) + "/test/data/default_fitted.yaml";
  auto run = [&](const std::string& model, const std::string& options, const std::string& out) {
    return trackBag("--bag '" + path("scene.bag") + "' --out '" + path(out) + "' --model '" +
                    model + "' --quiet " + options);
  };
  const ToolRun own = run(fitted, "--background-frames 0", "own.csv");
  EXPECT_EQ(own.status, 0) << own.err;
  const SkinParams gate = personalSkinGate(loadHandModel(fitted));
  EXPECT_NE(
      own.out.find("skin gate: the model's colours (the user's skin): hue " +
                   shortNumber(gate.hue_min_deg) + ".." + shortNumber(gate.hue_max_deg) + " deg"),
      std::string::npos)
      << own.out;
  // The generic gate keeps more than the hand: the starts charge the model's area (PipelineParams::
  // skin_gate_start_area_weight); the user's own gate does not need it.
  const std::string area_charged = "starts scored with the model's area charged (lambda " +
                                   shortNumber(PipelineParams().skin_gate_start_area_weight) + ",";
  EXPECT_EQ(own.out.find(area_charged), std::string::npos) << own.out;
  const ToolRun generic = run(fitted, "--background-frames 0 --generic-skin-gate", "generic.csv");
  EXPECT_NE(generic.out.find("skin gate: generic (--generic-skin-gate): hue -25..50 deg"),
            std::string::npos)
      << generic.out << generic.err;
  EXPECT_NE(generic.out.find(area_charged), std::string::npos) << generic.out;
  const ToolRun default_model =
      run(sag_test::modelPath("sag"), "--background-frames 0", "default.csv");
  EXPECT_NE(default_model.out.find("skin gate: generic (the model's colours are not the user's"),
            std::string::npos)
      << default_model.out << default_model.err;
  const ToolRun plate = run(fitted, "--background-frames 3", "plate.csv");
  EXPECT_EQ(plate.out.find("skin gate:"), std::string::npos) << plate.out;
  // Fitted colours that are not skin (sampled from a blue desk): the generic gate, and why.
  std::string text;
  {
    std::ifstream in(fitted);
    std::stringstream buffer;
    buffer << in.rdbuf();
    text = buffer.str();
  }
  for (std::size_t at = text.find("hsv: ["); at != std::string::npos;
       at = text.find("hsv: [", at + 1)) {
    text.replace(at, text.find(']', at) - at + 1, "hsv: [216, 0.36, 0.55]");
  }
  std::ofstream(path("desk_colours.yaml")) << text;
  const ToolRun desk = run(path("desk_colours.yaml"), "--background-frames 0", "desk.csv");
  EXPECT_NE(desk.out.find("skin gate: generic, not the model's (personal skin gate: only 0 of 17 "
                          "colours are skin-coloured"),
            std::string::npos)
      << desk.out << desk.err;
}

// A left hand rendered in the studio (render_bag --hand left; the surface, not the model's
// ellipses) and a right one: --hand auto names each after the first second with the hand, and
// tracks it as the explicit --hand of that side does, byte for byte. The other side is far off,
// with every frame "tracked" (doc/studio.md, "Left hands").
TEST_F(TrackBagTool, TrackBagTellsALeftHandFromARightOne) {
  const std::string config = std::string(SAG_SOURCE_DIR) + "/config";
  auto render = [&](Handedness hand, const std::string& name) {
    RenderBagOptions options;
    options.sequence = "pinch";
    options.hand = hand;
    options.out = path(name);
    options.gt_csv = path(name + ".gt.csv");
    options.config_dir = config;
    options.frames = 50;  // 10 without the hand, then 40: 25 to decide, 15 more
    renderStudioBag(options, nullptr);
    return options.out;
  };
  auto run = [&](const std::string& bag, const std::string& hand, const std::string& out) {
    const ToolRun result = trackBag("--bag '" + bag + "' --out '" + path(out) + "' --model '" +
                                    sag_test::modelPath("sag") + "' --quiet --hand " + hand);
    EXPECT_EQ(result.status, 0) << result.err;
    return result;
  };
  auto contents = [&](const std::string& name) {
    std::ifstream in(path(name));
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  // Mean fingertip error (mm) of a track against the bag's truth, matched by stamp.
  auto fingertipError = [&](const std::string& track, const std::string& truth) {
    const TrackingCsv tracked = readTrackingCsv(path(track));
    const TrackingCsv true_rows = readTrackingCsv(path(truth));
    double sum = 0.0;
    int n = 0;
    for (const TrackingCsvRow& row : tracked.rows) {
      for (const TrackingCsvRow& t : true_rows.rows) {
        if (std::abs(t.stamp - row.stamp) > 1e-4) continue;
        sum += meanFingertipError(row.fingertips, t.fingertips);
        ++n;
      }
    }
    EXPECT_GT(n, 0);
    return n > 0 ? 1000.0 * sum / n : 0.0;
  };
  const std::string left = render(Handedness::kLeft, "left.bag");
  const ToolRun automatic = run(left, "auto", "left_auto.csv");
  EXPECT_NE(automatic.out.find("hand:      left (higher than a right hand in "), std::string::npos)
      << automatic.out;
  EXPECT_NE(automatic.out.find(" of 25 sets, by "), std::string::npos) << automatic.out;
  EXPECT_EQ(automatic.out.find("close"), std::string::npos) << automatic.out;
  run(left, "left", "left_left.csv");
  run(left, "right", "left_right.csv");
  EXPECT_EQ(contents("left_auto.csv"), contents("left_left.csv"));
  const double as_left = fingertipError("left_left.csv", "left.bag.gt.csv");
  const double as_right = fingertipError("left_right.csv", "left.bag.gt.csv");
  std::printf("a left hand tracked as a left hand: %.1f mm, as a right hand: %.1f mm\n", as_left,
              as_right);
  EXPECT_LT(as_left, 10.0);
  EXPECT_GT(as_right, 2.0 * as_left);
  // An explicit side is not second-guessed: no "hand:" line.
  EXPECT_EQ(run(left, "left", "again.csv").out.find("hand:"), std::string::npos);

  const std::string right = render(Handedness::kRight, "right.bag");
  const ToolRun right_auto = run(right, "auto", "right_auto.csv");
  EXPECT_NE(right_auto.out.find("hand:      right (higher than a left hand in "), std::string::npos)
      << right_auto.out;
  run(right, "right", "right_right.csv");
  EXPECT_EQ(contents("right_auto.csv"), contents("right_right.csv"));
}

TEST_F(TrackBagTool, TrackBagReportsAnEmptyResult) {
  // Only the desk: nothing to track is an error, not a silently empty CSV.
  const std::vector<Camera> cameras = sag_test::renderedRig();
  {
    BagWriter writer(path("desk.bag"));
    writer.writeStaticTransforms("world", cameras, frameTime(0));
    for (int frame = 0; frame < 5; ++frame) {
      for (const Camera& camera : cameras) {
        writer.writeCameraImage(camera, sag_test::desk(camera), frameTime(frame));
      }
    }
  }
  const ToolRun run = trackBag("--bag '" + path("desk.bag") + "' --out '" + path("desk.csv") +
                               "' " + modelArgument() + " --quiet");
  EXPECT_EQ(run.status, 1);
  EXPECT_EQ(run.err,
            "track_bag: error: no frame was tracked: the hand was not found in the 2 "
            "frames after the 3 background frames; " +
                path("desk.csv") + " was not written\n");
  EXPECT_NE(run.out.find("output:    none (no frame was tracked"), std::string::npos) << run.out;
  // No header-only CSV that could pass for a result; an older file there is left alone.
  EXPECT_FALSE(fs::exists(path("desk.csv")));
  write("old.csv", "an earlier result\n");
  EXPECT_EQ(trackBag("--bag '" + path("desk.bag") + "' --out '" + path("old.csv") + "' " +
                     modelArgument() + " --quiet --overwrite")
                .status,
            1);
  EXPECT_EQ(readAll(path("old.csv")), "an earlier result\n");
}

// With --stamp-tolerance 0 (identical stamps only), cameras stamped 5 us apart are never seen
// together, and the error says so.
TEST_F(TrackBagTool, TrackBagNamesAStampMismatchInsteadOfAMissingHand) {
  const std::string bag = writeSceneBag("skewed.bag", 5e-6);
  const ToolRun run = trackBag("--bag '" + bag + "' --out '" + path("skewed.csv") + "' " +
                               modelArgument() + " --quiet --stamp-tolerance 0");
  EXPECT_EQ(run.status, 1);
  EXPECT_EQ(run.err.rfind("track_bag: error: no frame was tracked: the cameras' stamps do not "
                          "match (",
                          0),
            0u)
      << run.err;
  EXPECT_NE(run.err.find("first: /cam1/image_raw frame 1 at 1000.000005 vs cam0 at 1000.000000"),
            std::string::npos)
      << run.err;
  EXPECT_NE(run.out.find("warning:"), std::string::npos) << run.out;
}

// Cameras that are not stamped together (each camera 1 ms after the one before: the last one 4 ms
// after the first) are one set within the default stamp tolerance of 5 ms: the bag tracks as if
// they were, and the summary says how far apart the stamps were.
TEST_F(TrackBagTool, TrackBagGroupsCamerasStampedMillisecondsApart) {
  const std::string bag = writeSceneBag("apart.bag", 1e-3);
  const ToolRun run = trackBag("--bag '" + bag + "' --out '" + path("apart.csv") + "' " +
                               modelArgument() + " --quiet");
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out.find("with a camera missing"), std::string::npos) << run.out;
  const int cameras = static_cast<int>(sag_test::renderedRig().size());
  EXPECT_NE(run.out.find(
                "stamps:    " + std::to_string((cameras - 1) * (kBackgroundFrames + kHandFrames)) +
                " images joined a set of another camera's stamp, up to " +
                std::to_string(cameras - 1) + ".00 ms apart"),
            std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("output:    8 rows (8 tracked or started, 0 lost)"), std::string::npos)
      << run.out;
  // A tolerance below the skew leaves every set with one camera.
  const ToolRun strict = trackBag("--bag '" + bag + "' --out '" + path("strict.csv") + "' " +
                                  modelArgument() + " --quiet --stamp-tolerance 0.0005");
  EXPECT_NE(strict.out.find("with a camera missing"), std::string::npos) << strict.out;
  EXPECT_NE(
      strict.out.find("the cameras are not stamped together, so these are never seen together"),
      std::string::npos)
      << strict.out;
  EXPECT_EQ(trackBag("--bag '" + bag + "' --out '" + path("x.csv") + "' --stamp-tolerance -1").err,
            "track_bag: --stamp-tolerance expects a number within [0, 1], got '-1'\n"
            "Run 'track_bag --help' for the options.\n");
}

// Images whose header stamps go backwards (recorded after later images of their camera, e.g. a
// driver that republishes old frames): their sets were already tracked, so they are dropped, and
// the summary says how many and names the first with its stamp and the one it came after. When
// they outnumber the sets, the error says so instead of "the hand was not found".
TEST_F(TrackBagTool, TrackBagNamesImagesWhoseStampsGoBackwards) {
  const std::vector<Camera> cameras = sag_test::renderedRig();
  // cam<camera>'s desk stamped as frame `stamp_frame`, recorded at `recorded`.
  const auto writeStamped = [&](BagWriter* writer, int camera, int stamp_frame,
                                const ros::Time& recorded) {
    std_msgs::Header header;
    header.stamp = frameTime(stamp_frame);
    header.frame_id = opticalFrame(cameras[camera].name);
    writer->write(imageTopicOf(cameras[camera]), recorded,
                  toImageMsg(sag_test::desk(cameras[camera]), header));
  };
  // The scene, then cam0 and cam2 once more with the stamps of frames 4 and 6, recorded last.
  const int frames = kBackgroundFrames + kHandFrames;
  const std::string bag = writeSceneBag("backward.bag", 0.0, [&](BagWriter* writer) {
    writeStamped(writer, 0, 4, frameTime(frames));
    writeStamped(writer, 2, 6, frameTime(frames + 1));
  });
  ToolRun run = trackBag("--bag '" + bag + "' --out '" + path("backward.csv") + "' " +
                         modelArgument() + " --quiet");
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.out.find("frames:    11 (3 background, 8 tracked, 0 lost, 0 without a hand pose), "
                         "2 images dropped\n"),
            std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("  warning:   2 images with stamps going backwards (first: "
                         "/cam0/image_raw frame 12 at 1000.160000 after 1000.400000); images whose "
                         "set was already read are dropped\n"),
            std::string::npos)
      << run.out;
  // One row per set, in the order of the stamps: the late images made no second frame 4 or 6.
  const TrackingCsv csv = readTrackingCsv(path("backward.csv"));
  ASSERT_EQ(csv.rows.size(), static_cast<std::size_t>(kHandFrames));
  for (std::size_t k = 1; k < csv.rows.size(); ++k) {
    EXPECT_GT(csv.rows[k].stamp, csv.rows[k - 1].stamp) << k;
  }

  // 4 sets of the desk, then 20 images stamped as the first 3 frames: nothing is tracked, and the
  // error names the backward stamps, not a missing hand.
  {
    BagWriter writer(path("mostly_backward.bag"));
    writer.writeStaticTransforms("world", cameras, frameTime(0));
    for (int frame = 0; frame < 4; ++frame) {
      for (const Camera& camera : cameras) {
        writer.writeCameraImage(camera, sag_test::desk(camera), frameTime(frame));
      }
    }
    const int count = static_cast<int>(cameras.size());
    for (int k = 0; k < 20; ++k) {
      writeStamped(&writer, k % count, (k / count) % 3, frameTime(4) + ros::Duration(0.001 * k));
    }
  }
  run = trackBag("--bag '" + path("mostly_backward.bag") + "' --out '" +
                 path("mostly_backward.csv") + "' " + modelArgument() + " --quiet");
  EXPECT_EQ(run.status, 1);
  EXPECT_EQ(
      run.err,
      "track_bag: error: no frame was tracked: 20 images were dropped because their stamps go "
      "backwards (first: /cam0/image_raw frame 5 at 1000.000000 after 1000.120000), against 4 sets "
      "kept; the bag's images must come in the order of their stamps; " +
          path("mostly_backward.csv") + " was not written\n");
  EXPECT_FALSE(fs::exists(path("mostly_backward.csv")));
}

// The sheets' tile step (track_bag's overlays, calibrate_hand's contact sheet): a tile of another
// size is resized into its place, labelled in white at its top left, and nothing else is touched.
TEST(OverlaySheet, PastesATileResizedAndLabelledInItsPlaceOnly) {
  cv::Mat sheet(60, 100, CV_8UC3, cv::Scalar(10, 20, 30));
  const cv::Mat tile(80, 120, CV_8UC3, cv::Scalar(0, 0, 200));  // twice the place's size
  const cv::Rect where(40, 20, 60, 40);
  pasteSheetTile(tile, "cam0", where, &sheet);
  EXPECT_EQ(sheet.at<cv::Vec3b>(55, 95), cv::Vec3b(0, 0, 200));   // the tile, bottom right
  EXPECT_EQ(sheet.at<cv::Vec3b>(10, 10), cv::Vec3b(10, 20, 30));  // outside: as it was
  EXPECT_EQ(sheet.at<cv::Vec3b>(19, 95), cv::Vec3b(10, 20, 30));  // the row above the place
  int white = 0;
  for (int y = where.y; y < where.y + 20; ++y) {
    for (int x = where.x; x < where.x + 40; ++x) {
      const cv::Vec3b p = sheet.at<cv::Vec3b>(y, x);
      white += p[0] > 200 && p[1] > 200 && p[2] > 200;
    }
  }
  EXPECT_GT(white, 20) << "the label's pixels";
}

// --overlay-dir: the tracked model drawn over every camera's image for every N-th set after the
// background and the start; a folder that already holds a file is refused before the bag is read.
TEST_F(TrackBagTool, TrackBagDrawsTheTrackedModelOverTheImages) {
  const HandModel model = loadHandModel(sag_test::modelPath("sag"));
  const std::vector<Camera> cameras = sag_test::renderedRig();
  const std::string bag = writeSceneBag("scene.bag");
  const std::string overlays = path("overlays");
  const ToolRun run =
      trackBag("--bag '" + bag + "' --out '" + path("track.csv") + "' " + modelArgument() +
               " --quiet --overlay-dir '" + overlays + "' --overlay-every 3");
  ASSERT_EQ(run.status, 0) << run.err << run.out;
  // Sets 4..11 carry the hand: 4 (the start, and the first of every third), 7 and 10.
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(overlays)) {
    names.insert(entry.path().filename().string());
  }
  EXPECT_EQ(names,
            (std::set<std::string>{"frame_000004.png", "frame_000007.png", "frame_000010.png"}));
  EXPECT_NE(run.out.find("overlays:  3 pictures in " + overlays), std::string::npos) << run.out;
  EXPECT_EQ(readTrackingCsv(path("track.csv")).rows.size(), static_cast<std::size_t>(kHandFrames));

  // Four cameras: three tiles in the first row, one in the second, under a header line.
  const cv::Mat sheet = cv::imread(overlayPath(overlays, 4), cv::IMREAD_COLOR);
  ASSERT_FALSE(sheet.empty());
  const int w = cameras[0].width, h = cameras[0].height;
  const int header = sheet.rows - 2 * h;
  ASSERT_EQ(sheet.cols, 3 * w);
  ASSERT_GT(header, 0);
  // Camera 0's tile: the background dimmed (a corner of the desk), the model's ellipses drawn in
  // yellow where the plain image has none.
  const cv::Mat image = sag_test::renderHand(model, truthAt(model, 0), cameras[0]);  // RGB
  const cv::Vec3b plain = image.at<cv::Vec3b>(h - 3, w - 3);
  const cv::Vec3b drawn = sheet.at<cv::Vec3b>(header + h - 3, w - 3);  // BGR
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(drawn[2 - k], 0.4 * plain[k], 1.0) << k;
  auto yellowPixels = [](const cv::Mat& bgr) {
    int count = 0;
    for (int y = 0; y < bgr.rows; ++y) {
      for (int x = 0; x < bgr.cols; ++x) {
        const cv::Vec3b p = bgr.at<cv::Vec3b>(y, x);
        count += p[2] > 200 && p[1] > 180 && p[0] < 90;
      }
    }
    return count;
  };
  cv::Mat plain_bgr;
  cv::cvtColor(image, plain_bgr, cv::COLOR_RGB2BGR);
  EXPECT_GT(yellowPixels(sheet(cv::Rect(0, header, w, h))), yellowPixels(plain_bgr) + 100);

  // A folder that holds anything is refused before the bag is read; nothing in it is touched.
  const ToolRun again = trackBag("--bag '" + bag + "' --out '" + path("again.csv") + "' " +
                                 modelArgument() + " --quiet --overlay-dir '" + overlays + "'");
  EXPECT_EQ(again.status, 1);
  EXPECT_EQ(again.err, "track_bag: error: --overlay-dir " + overlays +
                           ": already holds files; give a new or empty folder (the pictures "
                           "never replace a file)\n");
  EXPECT_FALSE(fs::exists(path("again.csv")));
  const ToolRun file =
      trackBag("--bag '" + bag + "' --out '" + path("again.csv") + "' " + modelArgument() +
               " --quiet --overlay-dir '" + path("track.csv") + "'");
  EXPECT_EQ(file.status, 1);
  EXPECT_EQ(file.err,
            "track_bag: error: --overlay-dir " + path("track.csv") + ": is not a folder\n");
  const ToolRun every = trackBag("--bag '" + bag + "' --out '" + path("again.csv") + "' " +
                                 modelArgument() + " --quiet --overlay-every 5");
  EXPECT_EQ(every.status, 2) << every.err;
  EXPECT_NE(every.err.find("--overlay-every needs --overlay-dir"), std::string::npos) << every.err;
}

TEST_F(TrackBagTool, TrackBagNeverOverwritesAnInputOrLosesAnOldOutput) {
  const std::string bag = writeSceneBag("scene.bag");
  const std::string bag_bytes = readAll(bag);
  fs::create_symlink(bag, path("link.bag"));
  fs::create_hard_link(bag, path("hard.bag"));
  for (const std::string& out : {bag, path("link.bag"), path("hard.bag")}) {
    const ToolRun run =
        trackBag("--bag '" + bag + "' --out '" + out + "' " + modelArgument() + " --quiet");
    EXPECT_EQ(run.status, 1);
    EXPECT_EQ(run.err, "track_bag: error: --out " + out + " is the input " + bag +
                           "; refusing to overwrite an input\n");
  }
  const ToolRun model_run = trackBag("--bag '" + bag + "' --out '" + sag_test::modelPath("sag") +
                                     "' " + modelArgument() + " --quiet");
  EXPECT_EQ(model_run.status, 1);
  EXPECT_NE(model_run.err.find("is the input"), std::string::npos) << model_run.err;
  EXPECT_EQ(readAll(bag), bag_bytes);

  // A run that fails half way (an rgba8 image in frame 5) leaves the old output as it was and no
  // temporary file.
  const std::vector<Camera> cameras = sag_test::renderedRig();
  {
    BagWriter writer(path("broken.bag"));
    writer.writeStaticTransforms("world", cameras, frameTime(0));
    for (int frame = 0; frame < kBackgroundFrames + kHandFrames; ++frame) {
      for (const Camera& camera : cameras) {
        if (frame != 5 || camera.name != "cam0") {
          writer.writeCameraImage(camera, sag_test::desk(camera), frameTime(frame));
          continue;
        }
        std_msgs::Header header;
        header.stamp = frameTime(frame);
        header.frame_id = opticalFrame(camera.name);
        sensor_msgs::Image image = toImageMsg(sag_test::desk(camera), header);
        image.encoding = "rgba8";
        writer.write(imageTopicOf(camera), header.stamp, image);
      }
    }
  }
  write("out.csv", "an earlier result\n");
  const auto files_before = std::distance(fs::directory_iterator(dir_), fs::directory_iterator());
  const ToolRun broken = trackBag("--bag '" + path("broken.bag") + "' --out '" + path("out.csv") +
                                  "' " + modelArgument() + " --quiet --overwrite");
  EXPECT_EQ(broken.status, 1);
  EXPECT_NE(broken.err.find("unsupported image encoding 'rgba8'"), std::string::npos) << broken.err;
  EXPECT_EQ(readAll(path("out.csv")), "an earlier result\n");
  // stdout.txt and stderr.txt of the run already existed.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), files_before);

  // A file at --out is not replaced, even by a run that would succeed, unless --overwrite.
  const ToolRun kept = trackBag("--bag '" + bag + "' --out '" + path("out.csv") + "' " +
                                modelArgument() + " --quiet");
  EXPECT_EQ(kept.status, 1);
  EXPECT_EQ(kept.err, "track_bag: error: --out " + path("out.csv") +
                          " exists; it is not replaced (--overwrite replaces it, or choose another "
                          "name)\n");
  EXPECT_EQ(readAll(path("out.csv")), "an earlier result\n");
  const ToolRun replaced = trackBag("--bag '" + bag + "' --out '" + path("out.csv") + "' " +
                                    modelArgument() + " --quiet --overwrite");
  ASSERT_EQ(replaced.status, 0) << replaced.err;
  EXPECT_EQ(readTrackingCsv(path("out.csv")).rows.size(), static_cast<std::size_t>(kHandFrames));
}

TEST_F(TrackBagTool, TrackBagRejectsBadInputs) {
  const std::vector<Camera> cameras = sag_test::renderedRig();
  // A bag of 2 frames where `edit` may change or drop each image and camera_info.
  auto bag = [&](const std::string& name, auto edit, bool with_tf = true) {
    BagWriter writer(path(name));
    if (with_tf) writer.writeStaticTransforms("world", cameras, frameTime(0));
    for (int frame = 0; frame < 2; ++frame) {
      for (std::size_t i = 0; i < 3; ++i) {
        std_msgs::Header header;
        header.stamp = frameTime(frame);
        header.frame_id = opticalFrame(cameras[i].name);
        sensor_msgs::Image image = toImageMsg(sag_test::desk(cameras[i]), header);
        sensor_msgs::CameraInfo info = toCameraInfo(cameras[i]);
        info.header = header;
        bool write_image = true, write_info = true;
        edit(static_cast<int>(i), &image, &info, &write_image, &write_info);
        if (write_image) writer.write(imageTopicOf(cameras[i]), header.stamp, image);
        if (write_info) writer.write(cameraInfoTopicOf(cameras[i]), header.stamp, info);
      }
    }
    return path(name);
  };

  expectError(path("absent.bag"), "bag file does not exist");
  { BagWriter empty(path("empty.bag")); }
  expectError(path("empty.bag"), "the bag is empty: no frames");
  {
    BagWriter writer(path("chatter.bag"));
    std_msgs::String text;
    writer.write("/chatter", frameTime(0), text);
  }
  expectError(path("chatter.bag"),
              "no image topics (/cam<i>/image_raw) in the bag; it has: /chatter");
  expectError(bag("noinfo.bag", [](int i, sensor_msgs::Image*, sensor_msgs::CameraInfo*, bool*,
                                   bool* write_info) { *write_info = i != 2; }),
              "camera cam2 has no camera_info (no messages on /cam2/camera_info)");
  expectError(bag(
                  "notf.bag",
                  [](int, sensor_msgs::Image*, sensor_msgs::CameraInfo*, bool*, bool*) {}, false),
              "missing extrinsics for camera cam0: the bag has no /tf_static");
  expectError(bag("mono.bag",
                  [](int i, sensor_msgs::Image* image, sensor_msgs::CameraInfo*, bool*, bool*) {
                    if (i != 1) return;
                    image->encoding = "mono8";
                    image->step = image->width;
                    image->data.resize(image->step * image->height);
                  }),
              "/cam1/image_raw at 1000.000000: mono image (encoding 'mono8'): the tracker needs "
              "colour images, rgb8 or bgr8");
  expectError(bag("rgba.bag",
                  [](int i, sensor_msgs::Image* image, sensor_msgs::CameraInfo*, bool*, bool*) {
                    if (i == 0) image->encoding = "rgba8";
                  }),
              "/cam0/image_raw at 1000.000000: unsupported image encoding 'rgba8' (expected rgb8 "
              "or bgr8)");
  // Data beyond step x height was silently ignored (too little was refused).
  expectError(bag("long.bag",
                  [](int i, sensor_msgs::Image* image, sensor_msgs::CameraInfo*, bool*, bool*) {
                    if (i == 1) image->data.resize(image->data.size() + 960);
                  }),
              "/cam1/image_raw at 1000.000000: malformed image: 231360 bytes for 320x240 with "
              "step 960, not step x height = 230400");
  expectError(bag("size.bag",
                  [](int i, sensor_msgs::Image*, sensor_msgs::CameraInfo* info, bool*, bool*) {
                    if (i == 2) info->width = 640;
                  }),
              "/cam2/image_raw at 1000.000000: image is 320x240 but its camera_info says 640x240");
  // Images of one camera only (the others' camera_info without images): named with the bag and
  // the camera, not "the tracker starts from at least 2 cameras ..., but there are 1".
  expectError(bag("one_camera.bag", [](int i, sensor_msgs::Image*, sensor_msgs::CameraInfo*,
                                       bool* write_image, bool*) { *write_image = i == 0; }),
              "images of 1 camera (cam0); the tracker starts from at least 2 cameras that see the "
              "hand");
}

TEST_F(TrackBagTool, TrackBagUsageErrors) {
  ToolRun run = trackBag("--out x.csv");
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.err, "track_bag: --bag is required\nRun 'track_bag --help' for the options.\n");
  run = trackBag("--bag a.bag --out x.csv --cameras 1,1");
  EXPECT_EQ(run.status, 2);
  // An option given twice: the first value was silently ignored (two --out, two --bag).
  run = trackBag("--bag a.bag --out x.csv --out y.csv");
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.err, "track_bag: --out is given twice\nRun 'track_bag --help' for the options.\n");
  // An explicitly empty value: --model "" ended with exit status 1 (no file ""), --root-frame ""
  // and --gt-csv "" were taken as the default.
  run = trackBag("--bag a.bag --out x.csv --model ''");
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.err,
            "track_bag: --model needs a value, got an empty one\nRun 'track_bag --help' for the "
            "options.\n");
  run = trackBag("--bag a.bag --out x.csv --root-frame ''");
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.err,
            "track_bag: --root-frame needs a value, got an empty one\nRun 'track_bag --help' for "
            "the options.\n");
  run = trackBag("--help");
  EXPECT_EQ(run.status, 0);
  EXPECT_NE(run.out.find("Usage: track_bag --bag IN.bag --out OUT.csv"), std::string::npos);
  run = trackBag("--bag a.bag --out '" + path("x.csv") + "' --model '" + path("nope.yaml") + "'");
  EXPECT_EQ(run.status, 1);
  EXPECT_NE(run.err.find("nope.yaml"), std::string::npos) << run.err;
}

// --out was checked only before the run: a file created there during the run was replaced by the
// CSV. The commit replaces nothing without --overwrite; the error names --out and the file the
// finished CSV was kept in. A dangling symlink at --out is something there too.
TEST_F(TrackBagTool, TrackBagReplacesNoFileCreatedAtOutDuringTheRun) {
  const std::string bag = writeSceneBag("scene.bag");
  TrackBagOptions options;
  options.bag = bag;
  options.out = path("race.csv");
  options.model = sag_test::modelPath("sag");
  options.background_frames = kBackgroundFrames;
  const std::string kept = sag_test::keptOutputOfARace(options.out, [&](std::ostream& stream) {
    ProgressBar progress(stream, /*interactive=*/false);
    sag_hand_tracker::trackBag(options, &progress);
  });
  ASSERT_FALSE(kept.empty());
  EXPECT_EQ(readTrackingCsv(kept).rows.size(), static_cast<std::size_t>(kHandFrames));

  // With --overwrite the file created meanwhile is replaced, as asked.
  options.overwrite = true;
  std::ostringstream quiet;
  ProgressBar plain(quiet, false);
  sag_hand_tracker::trackBag(options, &plain);
  EXPECT_EQ(readTrackingCsv(options.out).rows.size(), static_cast<std::size_t>(kHandFrames));

  fs::create_symlink("nothere.csv", path("dangling.csv"));
  const ToolRun run = trackBag("--bag '" + bag + "' --out '" + path("dangling.csv") + "' " +
                               modelArgument() + " --quiet");
  EXPECT_EQ(run.status, 1);
  EXPECT_EQ(run.err, "track_bag: error: --out " + path("dangling.csv") +
                         " exists; it is not replaced (--overwrite replaces it, or choose another "
                         "name)\n");
  EXPECT_TRUE(fs::is_symlink(path("dangling.csv")));
  EXPECT_FALSE(fs::exists(path("nothere.csv")));
}

// A std_msgs/String written on an image topic is stored under the topic's sensor_msgs/Image
// connection (rosbag keeps a topic's first one): the error said "malformed sensor_msgs/Image" only.
TEST_F(TrackBagTool, TrackBagNamesTheTypeOfAStringOnAnImageTopic) {
  const std::string bag = writeSceneBag("string.bag", 0.0, [](BagWriter* writer) {
    std_msgs::String text;
    text.data = "hello";
    writer->write("/cam1/image_raw", frameTime(20), text);
  });
  const ToolRun run = trackBag("--bag '" + bag + "' --out '" + path("string.csv") + "' " +
                               modelArgument() + " --quiet");
  EXPECT_EQ(run.status, 1);
  EXPECT_EQ(run.err.rfind("track_bag: error: " + bag + ": /cam1/image_raw at 1000.800000: ", 0), 0u)
      << run.err;
  EXPECT_NE(run.err.find("; its bytes are a std_msgs/String, not a sensor_msgs/Image"),
            std::string::npos)
      << run.err;
  EXPECT_FALSE(fs::exists(path("string.csv")));
}

// --background-frames beyond the bag: "the hand was not found in the 0 frames after the 3
// background frames" did not say that the bag has only those.
TEST_F(TrackBagTool, TrackBagSaysHowManyFramesABagOfBackgroundHas) {
  const std::string bag = writeSceneBag("short.bag");
  const int frames = kBackgroundFrames + kHandFrames;
  const ToolRun run = trackBag("--bag '" + bag + "' --out '" + path("short.csv") + "' --model '" +
                               sag_test::modelPath("sag") + "' --quiet --background-frames 1000");
  EXPECT_EQ(run.status, 1);
  EXPECT_EQ(run.err, "track_bag: error: no frame was tracked: the bag has " +
                         std::to_string(frames) +
                         " frames, all taken as background frames (--background-frames 1000): "
                         "none could show the hand (a recording with the hand in view from its "
                         "first frame needs --background-frames 0); " +
                         path("short.csv") + " was not written\n");
}

// A pair of photographs, or a hand held still for a few frames (render_bag --empty-frames 0 in
// the office: a head and portraits in the room too): with the default 10 background frames a
// plate would take every frame, so without --background-frames the bag is tracked without one
// (the skin gate and the room cues) and says so; with the option given it is not second-guessed.
TEST_F(TrackBagTool, TrackBagTracksABagTooShortForAPlateWithoutOne) {
  RenderBagOptions render;
  render.sequence = std::string(SAG_SOURCE_DIR) + "/test/data/still_hand.yaml";
  render.config_dir = std::string(SAG_SOURCE_DIR) + "/config";
  render.room = "office";
  render.empty_frames = 0;
  render.frames = 2;
  render.out = path("pair.bag");
  render.gt_csv = path("pair.gt.csv");
  renderStudioBag(render, nullptr);
  const std::string model = " --model '" + sag_test::modelPath("sag") + "' --quiet";
  const ToolRun run =
      trackBag("--bag '" + path("pair.bag") + "' --out '" + path("pair.csv") + "'" + model);
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.out.find("  note:      the bag has 2 images per camera at most, not more than the "
                         "10 background frames a plate needs: every frame tracked without one"),
            std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("(0 background, 2 tracked"), std::string::npos) << run.out;
  const TrackingCsv tracked = readTrackingCsv(path("pair.csv"));
  const TrackingCsv truth = readTrackingCsv(path("pair.gt.csv"));
  ASSERT_EQ(tracked.rows.size(), 2u);
  ASSERT_EQ(truth.rows.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_NEAR(tracked.rows[k].stamp, truth.rows[k].stamp, 1e-6);
    // The hand found in front of the cameras, in the right place (the still hand of the rooms'
    // tests: 2.8 mm over 40 frames).
    EXPECT_LT(1000.0 * meanFingertipError(tracked.rows[k].fingertips, truth.rows[k].fingertips),
              10.0)
        << k;
  }
  // Given explicitly, the plate takes the two frames and the error says what to do.
  const ToolRun given = trackBag("--bag '" + path("pair.bag") + "' --out '" + path("plate.csv") +
                                 "' --background-frames 10" + model);
  EXPECT_EQ(given.status, 1);
  EXPECT_NE(given.err.find("needs --background-frames 0"), std::string::npos) << given.err;
  EXPECT_EQ(given.out.find("note:"), std::string::npos) << given.out;
  EXPECT_FALSE(fs::exists(path("plate.csv")));
}
