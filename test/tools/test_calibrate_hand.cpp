// calibrate_hand end to end on studio bags written in the test: bad recordings (no hand, one view,
// too short) end with a clear message, exit status 1 and no file; a recording without the whole
// routine is fitted with a warning (refused with --require-routine); existing files are not
// replaced; the command line is checked. (The fit itself is tested in test/unit/test_hand_fit.cpp.)
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Image.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <optional>

#include "sag_hand_tracker/apps/calibrate_runner.h"
#include "sag_hand_tracker/apps/render_runner.h"
#include "sag_hand_tracker/apps/track_runner.h"
#include "sag_hand_tracker/fitting/hand_fit.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/studio/hand_surface.h"
#include "sag_hand_tracker/util/number_text.h"
#include "test_support/temp_files.h"

using namespace sag_hand_tracker;
namespace fs = std::filesystem;

namespace {

const std::string kConfig = std::string(SAG_SOURCE_DIR) + "/config";

class CalibrateHandTool : public sag_test::TempDirTest {
 protected:
  ToolRun calibrateHand(const std::string& arguments) const {
    return runTool(std::string("'") + SAG_BIN_DIR + "/calibrate_hand' --config-dir '" + kConfig +
                   "' --quiet " + arguments);
  }

  // The calibration routine (or `sequence`) rendered into a bag: `frames` frames (the first 10
  // without the hand).
  std::string routineBag(const std::string& name, int frames, const std::string& rig = "dexter5",
                         const std::string& sequence = "calibration_routine") {
    RenderBagOptions options;
    options.sequence = sequence;
    options.rig = rig;
    options.out = path(name);
    options.gt_csv = path(name + ".gt.csv");
    options.config_dir = kConfig;
    options.frames = frames;
    renderStudioBag(options, nullptr);
    return options.out;
  }

  // `in` written again as `name`, each image's header stamp given by `stamp(camera id, frame,
  // stamp)` (frame: its number on its topic, from 0), or the image left out when it gives none;
  // the order of the messages (their times in the bag) and every other message as they were.
  std::string restampedBag(
      const std::string& in, const std::string& name,
      const std::function<std::optional<ros::Time>(int, int, const ros::Time&)>& stamp) const {
    rosbag::Bag source(in);
    rosbag::Bag out(path(name), rosbag::bagmode::Write);
    std::map<std::string, int> frames;
    for (const rosbag::MessageInstance& message : rosbag::View(source)) {
      const std::string& topic = message.getTopic();
      const sensor_msgs::Image::ConstPtr image = message.instantiate<sensor_msgs::Image>();
      if (!image) {
        out.write(topic, message.getTime(), message);
        continue;
      }
      const int camera = std::stoi(topic.substr(4));  // "/cam<i>/image_raw"
      const std::optional<ros::Time> moved = stamp(camera, frames[topic]++, image->header.stamp);
      if (!moved) continue;
      sensor_msgs::Image copy = *image;
      copy.header.stamp = *moved;
      out.write(topic, message.getTime(), copy);
    }
    return path(name);
  }

  // Runs calibrate_hand, expects exit 1, `what` in the error, and no model file.
  void expectFailure(const std::string& bag, const std::string& what,
                     const std::string& extra = "") {
    const std::string out = path("hand.yaml");
    const ToolRun run = calibrateHand("--bag '" + bag + "' --out '" + out + "' --contact-sheet '" +
                                      path("sheet.png") + "' " + extra);
    EXPECT_EQ(run.status, 1) << run.err;
    EXPECT_EQ(run.err.rfind("calibrate_hand: error: ", 0), 0u) << run.err;
    EXPECT_NE(run.err.find(what), std::string::npos) << run.err;
    EXPECT_FALSE(fs::exists(out)) << "no model for a failed run";
    EXPECT_FALSE(fs::exists(path("sheet.png")));
    for (const auto& entry : fs::directory_iterator(dir_)) {
      EXPECT_EQ(entry.path().filename().string().find(".hand.yaml.tmp"), std::string::npos)
          << "temporary file left: " << entry.path();
    }
  }
};

}  // namespace

TEST_F(CalibrateHandTool, NoHandInTheRecording) {
  // 10 frames of the empty studio: 5 for the background, 5 more without the hand. The message
  // says the recording shows no hand (no foreground at all), not only that it was never found.
  const std::string bag = routineBag("empty.bag", 10);
  expectFailure(bag,
                "does not show the calibration routine (open hand, palm and back turned to the "
                "cameras, a fist; doc/calibration.md):\n  - no frame with the hand: no frame had "
                "foreground: the recording shows no hand (5 frames after the 5 background frames, "
                "cameras cam0 cam1 cam2 cam3 cam4)\n",
                "--background-frames 5");
  // Every frame taken as background.
  expectFailure(bag,
                "  - no frame with the hand: all 10 frames of the recording were background "
                "frames (--background-frames 10): none could show the hand\n",
                "--background-frames 10");
}

TEST_F(CalibrateHandTool, TooShortARecording) {
  // 10 empty frames and 0.8 s of the routine: the open hand only.
  const std::string bag = routineBag("short.bag", 30);
  expectFailure(bag, "frames with the hand, the fit needs 40");
  const ToolRun run = calibrateHand("--bag '" + bag + "' --out '" + path("hand.yaml") + "'");
  EXPECT_NE(run.err.find("the fit needs 2.0 s"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("no fist"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("the palm was not turned to a camera"), std::string::npos) << run.err;
}

// The first 3 s of another sequence (pinch: the back of the open hand to the cameras, no palm
// turned up, no fist): fitted from its open-hand frames, written, and the summary says what the
// routine would have added; --require-routine refuses it and writes nothing.
TEST_F(CalibrateHandTool, FitsTheFirstSecondsOfAnySequenceAndSaysWhatWasMissing) {
  const std::string bag = routineBag("pinch.bag", 75, "dexter5", "pinch");
  expectFailure(bag, "does not show the calibration routine", "--require-routine");
  expectFailure(bag, "no fist", "--require-routine");

  const std::string out = path("hand.yaml");
  // A contact sheet whose name does not end in .png is a PNG all the same (written by its
  // extension, it failed after the fit).
  const std::string sheet = path("sheet.img");
  const ToolRun run =
      calibrateHand("--bag '" + bag + "' --out '" + out + "' --contact-sheet '" + sheet + "'");
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(readAll(sheet).substr(0, 4), "\x89PNG");
  EXPECT_NE(run.out.find("warning:      the recording does not show the whole routine"),
            std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("- no fist (0 frames)"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("- the palm was not turned to a camera"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("used by the fit (open hand)"), std::string::npos) << run.out;
  EXPECT_TRUE(fs::exists(out));
  const HandModel fitted = loadHandModel(out);
  EXPECT_TRUE(fitted.colours_fitted);
}

// --truth-shape compares with the studio hand shaped from the skeleton it was rendered from, not
// from the start model: started from a model with 10 % longer fingers (as one starts from an
// earlier fit), the printed errors are the fitted model's against the default skeleton, and
// --truth-model names another skeleton.
TEST_F(CalibrateHandTool, ComparesWithTheSkeletonTheHandWasRenderedFrom) {
  const std::string bag = routineBag("routine.bag", 72);  // the default hand, 2.5 s
  const HandModel sag = loadHandModel(trackBagModelPath("sag", kConfig));
  studio::HandShape longer_fingers;
  longer_fingers.finger_length.fill(1.1);
  const HandModel start = studio::shapeHandModel(sag, longer_fingers);
  const std::string start_path = path("longer_fingers.yaml");
  std::ofstream(start_path) << formatHandModel(start);

  auto worstBoneLine = [](const SkeletonErrors& e) {
    return "worst bone " + fixedNumber(100.0 * e.worst_bone, 1) + " %, " +
           std::to_string(e.bonesWithin(0.05)) + " of 15 bones within 5 %";
  };
  const std::string common = "--bag '" + bag + "' --model '" + start_path +
                             "' --truth-shape default --max-frames 4 --rounds 1";
  const ToolRun run = calibrateHand(common + " --out '" + path("fit.yaml") + "'");
  ASSERT_EQ(run.status, 0) << run.err;
  const HandModel fitted = loadHandModel(path("fit.yaml"));
  const SkeletonErrors against_sag = compareSkeletons(fitted, sag);
  const SkeletonErrors against_start = compareSkeletons(fitted, start);
  ASSERT_NE(worstBoneLine(against_sag), worstBoneLine(against_start));
  EXPECT_NE(run.out.find(worstBoneLine(against_sag)), std::string::npos) << run.out;

  const ToolRun named = calibrateHand(common + " --truth-model '" + start_path + "' --out '" +
                                      path("fit2.yaml") + "'");
  ASSERT_EQ(named.status, 0) << named.err;
  EXPECT_NE(
      named.out.find(worstBoneLine(compareSkeletons(loadHandModel(path("fit2.yaml")), start))),
      std::string::npos)
      << named.out;
}

TEST_F(CalibrateHandTool, OneView) {
  // A rig of dexter5's first camera only.
  const std::string rig = write("one_camera.yaml",
                                "root_frame: world\ncameras:\n"
                                "  - name: cam0\n    calibration: " +
                                    kConfig +
                                    "/rigs/dexter5/cam0.yaml\n"
                                    "    translation: [0.679731, 0, 0.466964]\n"
                                    "    rotation: [-0.605042113, "
                                    "-0.587501557, 0.374348205, 0.385524815]\n");
  expectFailure(routineBag("one_view.bag", 12, rig),
                "the recording has 1 camera; calibrate_hand needs at least 2 views of the hand");
}

// A start model of 1000 Gaussians (a hostile model file) made the fit run for hours: the model
// loader refuses more than 64 with the file and the line, before the recording is read, and
// nothing is written.
TEST_F(CalibrateHandTool, AStartModelOfAThousandGaussiansIsRefusedAtOnce) {
  std::ifstream in(kConfig + "/hand_sag_right.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::size_t at = text.find("gaussians:\n") + std::string("gaussians:\n").size();
  ASSERT_NE(at, std::string::npos);
  std::string many;
  for (int i = 0; i < 1000 - 17; ++i) {
    many += "  - {bone: palm, mean: [0, 0, 0], sigma: [0.01, 0.01, 0.01], hsv: [20, 0.4, 0.8]}\n";
  }
  text.insert(at, many);
  const std::string model = write("big_model.yaml", text);
  const long line = 1 + std::count(text.begin(), text.begin() + at, '\n');
  const std::string out = path("hand.yaml");
  const ToolRun run = calibrateHand("--bag '" + path("missing.bag") + "' --out '" + out +
                                    "' --model '" + model + "'");
  EXPECT_EQ(run.status, 1);
  EXPECT_EQ(run.err, "calibrate_hand: error: hand model " + model + ":" + std::to_string(line) +
                         ": key 'gaussians': has 1000 Gaussians, more than the limit of 64 for a "
                         "hand model (the SAG model has 17, the SoG model 30)\n");
  EXPECT_FALSE(fs::exists(out));
}

TEST_F(CalibrateHandTool, RefusesToReplaceFilesAndChecksTheCommandLine) {
  const std::string existing = write("hand.yaml", "precious\n");
  ToolRun run = calibrateHand("--bag '" + path("missing.bag") + "' --out '" + existing + "'");
  EXPECT_EQ(run.status, 1);
  EXPECT_NE(run.err.find("the file exists; calibrate_hand does not overwrite files"),
            std::string::npos)
      << run.err;
  EXPECT_EQ(readAll(existing), "precious\n");

  run = calibrateHand("--bag '" + path("missing.bag") + "' --out '" + path("new.yaml") + "'");
  EXPECT_EQ(run.status, 1);
  EXPECT_NE(run.err.find("missing.bag"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(path("new.yaml")));

  // An unknown studio hand for --truth-shape is refused before the recording is read.
  run = calibrateHand("--bag '" + path("missing.bag") + "' --out '" + path("new.yaml") +
                      "' --truth-shape no_such_hand");
  EXPECT_EQ(run.status, 1);
  EXPECT_NE(run.err.find("no hand shape 'no_such_hand'"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(path("new.yaml")));

  // The contact sheet at --out's name was renamed over the fitted model (exit status 0, the
  // model lost); a missing folder was found only when the fitted model was written. Both are
  // refused before the recording is read.
  run = calibrateHand("--bag '" + path("missing.bag") + "' --out '" + path("new.yaml") +
                      "' --contact-sheet '" + path("new.yaml") + "'");
  EXPECT_EQ(run.status, 1);
  EXPECT_EQ(run.err, "calibrate_hand: error: --contact-sheet " + path("new.yaml") +
                         " is the --out file; give the contact sheet a name of its own\n");
  run = calibrateHand("--bag '" + path("missing.bag") + "' --out '" + path("no/new.yaml") + "'");
  EXPECT_EQ(run.status, 1);
  EXPECT_EQ(run.err, "calibrate_hand: error: --out " + path("no/new.yaml") + ": the folder " +
                         path("no") + " does not exist\n");
  run = calibrateHand("--bag '" + path("missing.bag") + "' --out '" + path("new.yaml") +
                      "' --contact-sheet '" + path("no/sheet.png") + "'");
  EXPECT_EQ(run.status, 1);
  EXPECT_NE(run.err.find("--contact-sheet " + path("no/sheet.png") + ": the folder"),
            std::string::npos)
      << run.err;
  EXPECT_FALSE(fs::exists(path("new.yaml")));
  // A folder the model cannot be written in (here: a name too long for its temporary file; a
  // read-only folder alike) failed after the fit with "cannot write the file".
  const std::string long_name = path(std::string(250, 'h') + ".yaml");
  run = calibrateHand("--bag '" + path("missing.bag") + "' --out '" + long_name + "'");
  EXPECT_EQ(run.status, 1);
  EXPECT_EQ(run.err, "calibrate_hand: error: --out " + long_name + ": cannot create a file in " +
                         dir_.string() + ": File name too long\n");
  run = calibrateHand("--bag x.bag --out y.yaml --out z.yaml");
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("--out is given twice"), std::string::npos) << run.err;

  run = calibrateHand("--bag x.bag");
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("--out is required"), std::string::npos) << run.err;
  run = calibrateHand("--bag x.bag --out y.yaml --hand both");
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("--hand expects left or right, got 'both'"), std::string::npos);
  // An empty value was taken as the default (--model "": the SAG model) or as no file.
  run = calibrateHand("--bag x.bag --out y.yaml --model ''");
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("calibrate_hand: --model needs a value, got an empty one"),
            std::string::npos)
      << run.err;
  run = calibrateHand("--bag x.bag --out y.yaml --contact-sheet ''");
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("--contact-sheet needs a value, got an empty one"), std::string::npos)
      << run.err;
  run = calibrateHand("--help");
  EXPECT_EQ(run.status, 0);
  EXPECT_NE(run.out.find("Usage: calibrate_hand"), std::string::npos);
}

// The fitted model is committed without replacing anything: a file created at --out during the
// run stays, and the model is kept under the name the error gives (before, a check just before
// the rename left a window, and its refusal threw the fitted model away).
TEST_F(CalibrateHandTool, ReplacesNoFileCreatedAtOutDuringTheRun) {
  CalibrateHandOptions options;
  options.bag = routineBag("pinch.bag", 75, "dexter5", "pinch");
  options.out = path("hand.yaml");
  options.config_dir = kConfig;
  const std::string kept = sag_test::keptOutputOfARace(options.out, [&](std::ostream& stream) {
    ProgressBar progress(stream, /*interactive=*/false);
    sag_hand_tracker::calibrateHand(options, &progress);
  });
  ASSERT_FALSE(kept.empty());
  EXPECT_TRUE(loadHandModel(kept).colours_fitted) << "the fitted model is kept";
}

// The stamp checks of track_bag (the bag reader's), in calibrate_hand: found in a recording of
// the routine restamped after rendering. Before, a camera 30 ms late was fitted into a hand of
// size x0.88 with exit status 0, images whose stamps went backwards were dropped without a word,
// a clock set forward by an hour counted as an hour of routine, and a recording with one stamp
// was "all 1 frames of the recording were background frames".
TEST_F(CalibrateHandTool, NamesUnsynchronisedCamerasAndClocksThatJump) {
  const std::string bag = routineBag("routine.bag", 60);
  const auto first = [](int frames) {
    return [frames](int, int frame, const ros::Time& stamp) -> std::optional<ros::Time> {
      if (frame >= frames) return std::nullopt;
      return stamp;
    };
  };

  // cam2 stamped 30 ms late: refused, naming the first image out of step.
  const std::string late =
      restampedBag(bag, "late.bag",
                   [](int camera, int frame, const ros::Time& stamp) -> std::optional<ros::Time> {
                     if (frame >= 30) return std::nullopt;
                     return camera == 2 ? stamp + ros::Duration(0.03) : stamp;
                   });
  const ToolRun late_run = calibrateHand("--bag '" + late + "' --out '" + path("hand.yaml") + "'");
  EXPECT_EQ(late_run.status, 1);
  EXPECT_EQ(late_run.err.rfind(
                "calibrate_hand: error: " + late + ": the cameras' stamps do not match (", 0),
            0u)
      << late_run.err;
  EXPECT_NE(late_run.err.find(" ms or more) from another camera's set, first: /cam"),
            std::string::npos)
      << late_run.err;
  EXPECT_NE(late_run.err.find("; calibrate_hand fits no hand from cameras that are not stamped "
                              "together (their sets lack cameras and mix moments)\n"),
            std::string::npos)
      << late_run.err;
  EXPECT_FALSE(fs::exists(path("hand.yaml")));

  // 50 frames with the hand: 1.96 s, which read "in view for 2.0 s, the fit needs 2.0 s".
  const ToolRun short_run = calibrateHand("--bag '" + bag + "' --out '" + path("hand.yaml") + "'");
  EXPECT_EQ(short_run.status, 1);
  EXPECT_NE(short_run.err.find("the hand was in view for 1.9"), std::string::npos) << short_run.err;
  EXPECT_NE(short_run.err.find(" s, the fit needs 2.0 s"), std::string::npos) << short_run.err;

  // The clock set forward by an hour at frame 40 of 55: the hour is no time in view (45 frames
  // of the hand are 1.8 s), and the jump is named.
  const std::string forward = restampedBag(
      bag, "forward.bag", [](int, int frame, const ros::Time& stamp) -> std::optional<ros::Time> {
        if (frame >= 55) return std::nullopt;
        return frame >= 40 ? stamp + ros::Duration(3600.0) : stamp;
      });
  const ToolRun forward_run =
      calibrateHand("--bag '" + forward + "' --out '" + path("hand.yaml") + "'");
  EXPECT_EQ(forward_run.status, 1);
  EXPECT_NE(forward_run.err.find("the hand was in view for 1."), std::string::npos)
      << forward_run.err;
  EXPECT_NE(forward_run.err.find(
                "\nwarning: 5 images with stamps more than 10 s after their camera's previous "
                "image (first: /cam"),
            std::string::npos)
      << forward_run.err;
  EXPECT_NE(forward_run.err.find(
                "/image_raw frame 41 at 1400003601.600000 after 1400000001.560000); a clock set "
                "forward or a paused recording, read as the next frame"),
            std::string::npos)
      << forward_run.err;
  EXPECT_FALSE(fs::exists(path("hand.yaml")));

  // The clock set back by 1 s at frame 45: the images of the sets already read are dropped, and
  // said so.
  const std::string back = restampedBag(
      bag, "back.bag", [](int, int frame, const ros::Time& stamp) -> std::optional<ros::Time> {
        return frame >= 45 ? stamp - ros::Duration(1.0) : stamp;
      });
  const ToolRun back_run = calibrateHand("--bag '" + back + "' --out '" + path("hand.yaml") + "'");
  EXPECT_EQ(back_run.status, 1);
  EXPECT_NE(back_run.err.find("\nwarning: 75 images with stamps going backwards (first: /cam"),
            std::string::npos)
      << back_run.err;
  EXPECT_NE(back_run.err.find("/image_raw frame 46 at 1400000000.800000 after 1400000001.760000); "
                              "images whose set was already read are dropped"),
            std::string::npos)
      << back_run.err;

  // One stamp for every image: the repeats are dropped, and that is the reason given.
  const std::string same = restampedBag(restampedBag(bag, "ten.bag", first(10)), "same.bag",
                                        [](int, int, const ros::Time&) -> std::optional<ros::Time> {
                                          return ros::Time(1400000000.0);
                                        });
  const ToolRun same_run = calibrateHand("--bag '" + same + "' --out '" + path("hand.yaml") + "'");
  EXPECT_EQ(same_run.status, 1);
  EXPECT_NE(same_run.err.find("  - no frame with the hand: 45 images were dropped because they "
                              "repeat a stamp their camera already had (first: /cam"),
            std::string::npos)
      << same_run.err;
  EXPECT_NE(same_run.err.find("/image_raw frame 2 at 1400000000.000000), against 1 set kept; each "
                              "image of a camera needs a stamp of its own"),
            std::string::npos)
      << same_run.err;
}

// The stamp warnings are the summary's too, when the recording was fitted.
TEST(CalibrateHandSummaryText, ListsTheStampWarnings) {
  CalibrateHandSummary summary;
  summary.start_model = loadHandModel(kConfig + "/hand_sag_right.yaml");
  summary.fit.model = summary.start_model;
  summary.fit.shape.bone_length.assign(16, 1.0);
  summary.stamp_warnings = {"2 images with stamps going backwards (first: x)"};
  const std::string text = formatCalibrateHandSummary(summary);
  EXPECT_NE(text.find("\n  warning:      2 images with stamps going backwards (first: x)\n"),
            std::string::npos)
      << text;
}
