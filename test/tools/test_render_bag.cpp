// render_bag end to end: the bag holds exactly the interface track_bag reads (through BagReader),
// the ground truth in the bag and in the CSV agree with each other and with the studio sequence
// recomputed here, and bad input gets a one-line error and a non-zero exit.
#include <geometry_msgs/PoseArray.h>
#include <gtest/gtest.h>

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/JointState.h>
#include <sys/wait.h>
#include "test_support/temp_files.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <sstream>

#include "sag_hand_tracker/apps/csv.h"
#include "sag_hand_tracker/apps/render_runner.h"
#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/ros/bag_input.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/studio/sequence.h"

using namespace sag_hand_tracker;
namespace fs = std::filesystem;

namespace {

const std::string kConfig = std::string(SAG_SOURCE_DIR) + "/config";

class RenderBagTool : public sag_test::TempDirTest {
 protected:
  ToolRun renderBag(const std::string& arguments) const {
    return runTool(std::string("'") + SAG_BIN_DIR + "/render_bag' --config-dir '" + kConfig + "' " +
                   arguments);
  }
};

}  // namespace

TEST_F(RenderBagTool, WritesTheTrackBagInterfaceWithAgreeingGroundTruth) {
  constexpr int kFrames = 14;  // 10 empty + 4 with the hand
  const ToolRun run = renderBag("--sequence pinch --rig dexter5 --frames 14 --seed 3 --out '" +
                                path("p.bag") + "' --gt-csv '" + path("p.csv") + "' --preview '" +
                                path("p.png") + "' --preview-frame 12 --start-stamp 1000");
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.err.find("frames/s"), std::string::npos) << run.err;

  // The images: what track_bag reads, through the same reader.
  const CameraRig rig = loadCameraRig(kConfig + "/rigs/dexter5/rig.yaml");
  BagReader reader(path("p.bag"));
  ASSERT_EQ(reader.cameras().size(), 5u);
  EXPECT_EQ(reader.rootFrame(), "world");
  for (size_t c = 0; c < 5; ++c) {
    EXPECT_EQ(reader.cameras()[c].name, rig.cameras[c].name);
    EXPECT_LT((reader.cameras()[c].K - rig.cameras[c].K).norm(), 1e-9);
    EXPECT_LT(
        (reader.cameras()[c].world_to_camera.matrix() - rig.cameras[c].world_to_camera.matrix())
            .norm(),
        1e-6);
  }
  std::vector<std::int64_t> stamps;
  FrameSet set;
  while (reader.next(&set)) {
    ASSERT_EQ(set.images.size(), 5u) << "stamp " << set.stamp_ns;
    for (const CameraImage& image : set.images) {
      EXPECT_EQ(image.rgb.cols, 320);
      EXPECT_EQ(image.rgb.rows, 240);
    }
    stamps.push_back(set.stamp_ns);
  }
  ASSERT_EQ(stamps.size(), static_cast<size_t>(kFrames));
  for (int k = 0; k < kFrames; ++k) {
    EXPECT_EQ(stamps[k], 1000000000000LL + 40000000LL * k);  // 1000 s + k / 25 fps, exactly
  }

  // Ground truth in the bag, for the frames with the hand (10..13).
  rosbag::Bag bag(path("p.bag"));
  std::vector<sensor_msgs::JointState> joints;
  std::vector<geometry_msgs::PoseArray> tips;
  for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
    if (m.getTopic() == "/ground_truth/joint_states") {
      joints.push_back(*m.instantiate<sensor_msgs::JointState>());
      EXPECT_EQ(m.getTime(), joints.back().header.stamp);
    } else if (m.getTopic() == "/ground_truth/fingertips") {
      tips.push_back(*m.instantiate<geometry_msgs::PoseArray>());
    }
  }
  const HandModel model = loadHandModel(resolveModelPath("sag", kConfig));
  ASSERT_EQ(joints.size(), 4u);
  ASSERT_EQ(tips.size(), 4u);
  const TrackingCsv csv = readTrackingCsv(path("p.csv"));
  EXPECT_EQ(csv.parameter_names, model.parameterNames());
  ASSERT_EQ(csv.rows.size(), 4u);

  // The same sequence, recomputed here.
  const studio::StudioSequence sequence(
      model, studio::loadMotion(kConfig + "/motions/pinch.yaml", model, 3),
      studio::SequenceParams());
  for (int i = 0; i < 4; ++i) {
    SCOPED_TRACE("hand frame " + std::to_string(i));
    const studio::StudioFrame truth = sequence.frame(10 + i);
    EXPECT_EQ(static_cast<std::int64_t>(joints[i].header.stamp.toNSec()), stamps[10 + i]);
    EXPECT_EQ(tips[i].header.stamp, joints[i].header.stamp);
    EXPECT_EQ(joints[i].header.frame_id, "world");
    EXPECT_EQ(tips[i].header.frame_id, "world");
    EXPECT_EQ(joints[i].name, model.parameterNames());
    ASSERT_EQ(joints[i].position.size(), 26u);
    ASSERT_EQ(tips[i].poses.size(), 5u);
    const auto& row = csv.rows[i];
    EXPECT_NEAR(row.stamp, joints[i].header.stamp.toSec(), 1e-6);
    EXPECT_EQ(row.energy, 0.0);
    const PoseVector parameters = truth.pose.toVector();
    for (int p = 0; p < 26; ++p) {
      EXPECT_NEAR(joints[i].position[p], parameters[p], 1e-12);
      EXPECT_NEAR(row.parameters[p], joints[i].position[p], 1e-8);
    }
    for (int f = 0; f < 5; ++f) {
      const auto& position = tips[i].poses[f].position;
      const Eigen::Vector3d tip(position.x, position.y, position.z);
      EXPECT_LT((tip - truth.fingertips[f]).norm(), 1e-12);
      EXPECT_LT((row.fingertips[f] - tip).norm(), 1e-8);
    }
  }

  const cv::Mat sheet = cv::imread(path("p.png"));
  EXPECT_EQ(sheet.cols, 960);
  EXPECT_EQ(sheet.rows, 480);
}

// --threads renders a frame's views at once; the bag and its ground truth are the same bytes.
TEST_F(RenderBagTool, TheBagDoesNotDependOnTheThreads) {
  for (const std::string threads : {"1", "3"}) {
    const ToolRun run = renderBag("--sequence random --frames 14 --seed 5 --quiet --threads " +
                                  threads + " --out '" + path("t" + threads + ".bag") + "'");
    ASSERT_EQ(run.status, 0) << run.err;
  }
  auto bytes = [](const std::string& file) {
    std::ifstream in(file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  };
  const std::string one = bytes(path("t1.bag"));
  EXPECT_GT(one.size(), 1000000u);
  EXPECT_TRUE(one == bytes(path("t3.bag")));
  EXPECT_EQ(bytes(path("t1.gt.csv")), bytes(path("t3.gt.csv")));
}

TEST_F(RenderBagTool, BadInputGetsAOneLineErrorAndNonZeroExit) {
  const std::string out = " --out '" + path("x.bag") + "'";
  struct Case {
    std::string arguments;
    int status;
    std::string message;
  };
  std::ofstream(path("bad_shape.yaml")) << "shapes:\n  - {name: big, scale: 15}\n";
  std::ofstream(path("bad_motion.yaml"))
      << "keyframes:\n  - {time: 0, position: [0, 0, 0.15], joints: {index_pip_flex: 130}}\n";
  std::ofstream(path("short_motion.yaml"))
      << "duration: 1\nkeyframes:\n  - {time: 0, position: [0, 0, 0.15]}\n  - {time: 2}\n";
  std::ofstream(path("shape.yaml")) << "shapes:\n  - {name: mine, scale: 1.1}\n";
  std::filesystem::copy_file(kConfig + "/rigs/dexter5/cam1.yaml", path("cam1_copy.yaml"));
  const std::string calibration = readAll(path("cam1_copy.yaml"));
  std::ofstream(path("copied_rig.yaml"))
      << "root_frame: world\ncameras:\n"
      << "  - {name: cam0, calibration: cam1_copy.yaml, translation: [0.68, 0, 0.47], rotation: "
         "[0, "
         "0, 0, 1]}\n"
      << "  - {name: cam1, calibration: cam1_copy.yaml, translation: [0.26, 0.56, 0.66], rotation: "
         "[0, 0, 0, 1]}\n";
  // Session 30: cameras named otherwise than cam<i> were written on topics track_bag passes over.
  const std::string rig_dir = kConfig + "/rigs/dexter5/";
  std::ofstream(path("named_rig.yaml"))
      << "root_frame: world\ncameras:\n"
      << "  - {name: left, calibration: " << rig_dir
      << "cam0.yaml, translation: [0.68, 0, 0.47], rotation: [0, 0, 0, 1]}\n"
      << "  - {name: cam1, calibration: " << rig_dir
      << "cam1.yaml, translation: [0.26, 0.56, 0.66], rotation: [0, 0, 0, 1]}\n";
  const std::vector<Case> cases{
      {"--sequence pinch --rig '" + path("named_rig.yaml") + "'" + out, 1,
       "--rig " + path("named_rig.yaml") +
           ": camera 'left' is not named as a bag's cameras are (cam0 ... cam63, their images on "
           "/cam<i>/image_raw); track_bag would not read its images"},
      // Session 30: a rig's calibration file and a --shape file were replaced with --overwrite.
      {"--sequence pinch --frames 2 --shape '" + path("shape.yaml") + "' --out '" +
           path("shape.yaml") + "' --overwrite",
       1, "--out " + path("shape.yaml") + " is the input " + path("shape.yaml")},
      {"--sequence pinch --frames 2 --rig '" + path("copied_rig.yaml") + "' --out '" +
           path("cam1_copy.yaml") + "' --overwrite",
       1, "--out " + path("cam1_copy.yaml") + " is the input " + path("cam1_copy.yaml")},
      {"--sequence nosuch" + out, 1, "motion nosuch: does not exist"},
      {"--sequence pinch --out '" + path("same") + "' --gt-csv '" + path("same") + "'", 1,
       "--gt-csv " + path("same") + " is also --out " + path("same") +
           "; each output needs a file of its own"},
      {"--sequence pinch --gt-csv '" + path("g.png") + "' --preview '" + path("g.png") + "'" + out,
       1, "--preview " + path("g.png") + " is also --gt-csv " + path("g.png")},
      {"--sequence '" + path("bad_motion.yaml") + "' --out '" + path("bad_motion.yaml") + "'", 1,
       "--out " + path("bad_motion.yaml") + " is the input"},
      {"--sequence pinch --rig nosuchrig" + out, 1, "no camera rig 'nosuchrig'"},
      {"--sequence '" + path("bad_motion.yaml") + "'" + out, 1, "outside its limits"},
      {"--sequence '" + path("short_motion.yaml") + "'" + out, 1,
       "motion " + path("short_motion.yaml") +
           ":1: key 'duration': 1 s ends before the last keyframe's time 2 s (keyframes[1], line "
           "4)"},
      {"--sequence pinch --model '" + path("none.yaml") + "'" + out, 1, "none.yaml"},
      {"--sequence pinch --frames 5 --preview-frame 7 --preview '" + path("x.png") + "'" + out, 1,
       "--preview-frame 7 is past the last frame 4"},
      {"--sequence pinch --shape nosuch" + out, 1, "no hand shape 'nosuch'"},
      {"--sequence pinch --shape '" + path("bad_shape.yaml") + "'" + out, 1,
       "bad_shape.yaml:2: shape 'big' scale = 15 is outside [0.3, 3]"},
      {"--sequence pinch --shape ''" + out, 2, "--shape needs a value, got an empty one"},
      {"--sequence pinch --gt-csv ''" + out, 2, "--gt-csv needs a value, got an empty one"},
      {"--sequence pinch", 2, "--out is required"},
      {"--out x.bag", 2, "--sequence is required"},
      {"--sequence pinch --fps 0" + out, 2, "--fps must be in (0, 1000]"},
      {"--sequence pinch --frames two" + out, 2, "--frames needs a number, not 'two'"},
      {"--sequence pinch --colour red" + out, 2, "unknown argument '--colour'"},
      {"--sequence pinch --room attic" + out, 2, "--room: unknown studio room 'attic' (known: "},
      {"--sequence pinch --threads 0" + out, 2, "--threads needs an integer >= 1"},
      {"--sequence pinch --threads 17" + out, 2, "--threads must be at most 16"},
      // Session 30: a frame rate that gives the motion no frame wrote a bag without images, exit
      // status 0; a last stamp past 32-bit seconds failed with ros::Time's words.
      {"--sequence pinch --fps 0.001" + out, 1,
       "--fps 0.001 gives the motion no frame (its duration times the frame rate rounds to 0; "
       "--frames N sets the number of frames)"},
      {"--sequence pinch --fps 1e-300 --frames 2" + out, 1,
       "the last frame's stamp 1e+300 s (--start-stamp 1.4e+09, 2 frames at --fps 1e-300) is "
       "past a bag stamp's 32-bit seconds (4294967295)"},
      {"--sequence pinch --noise 1e308" + out, 2, "--noise must be at most 255 (8-bit levels)"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.arguments);
    const ToolRun run = renderBag(c.arguments + " --quiet");
    EXPECT_EQ(run.status, c.status);
    EXPECT_NE(run.err.find(c.message), std::string::npos) << run.err;
    if (c.status == 1) {
      EXPECT_EQ(run.err.find("render_bag: error: "), 0u) << run.err;
      EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    }
  }
  EXPECT_FALSE(std::filesystem::exists(path("x.bag"))) << "no bag from a failed run";
  EXPECT_EQ(readAll(path("shape.yaml")), "shapes:\n  - {name: mine, scale: 1.1}\n");
  EXPECT_EQ(readAll(path("cam1_copy.yaml")), calibration);
}

// Numbers beyond the limits were cast to int before they were checked (--threads 1e99 passed "at
// most 16", --frames 1e99 rendered the motion's length), size factors of 1e99 rendered a hand
// 1e98 m long, --start-stamp 1e99 failed in ros::Time, an option given twice kept the last value,
// `--out --quiet` named the bag "--quiet", and a --preview without an image writer failed after
// the rendering: all are usage errors now.
TEST(RenderBagArguments, OutOfRangeNumbersRepeatedOptionsAndPreviewNamesAreUsageErrors) {
  auto message = [](std::vector<std::string> extra) -> std::string {
    std::vector<std::string> args{"--sequence", "pinch", "--out", "x.bag"};
    args.insert(args.end(), extra.begin(), extra.end());
    try {
      parseRenderBagArguments(args);
    } catch (const UsageError& error) {
      return error.what();
    }
    return "no error";
  };
  EXPECT_EQ(message({"--threads", "1e99"}), "--threads must be at most 16");
  EXPECT_EQ(message({"--threads", "17"}), "--threads must be at most 16");
  EXPECT_EQ(message({"--frames", "1e99"}), "--frames must be at most 1000000");
  EXPECT_EQ(message({"--motion-blur", "1e99"}), "--motion-blur must be at most 1000");
  EXPECT_EQ(message({"--seed", "1e99"}), "--seed must be at most 9007199254740992");
  // Read as a double, 2^53 + 1 was 2^53 and passed.
  EXPECT_EQ(message({"--seed", "9007199254740993"}), "--seed must be at most 9007199254740992");
  EXPECT_EQ(message({"--seed", "99999999999999999999999"}),
            "--seed must be at most 9007199254740992");
  EXPECT_EQ(parseRenderBagArguments(
                {"--sequence", "pinch", "--out", "x.bag", "--seed", "9007199254740991"})
                .seed,
            9007199254740991ULL);
  EXPECT_EQ(message({"--seed", "-1"}), "--seed needs an integer >= 0");
  EXPECT_EQ(message({"--preview-frame", "1e99"}), "--preview-frame must be at most 1000000");
  EXPECT_EQ(message({"--hand-scale", "1e99"}), "--hand-scale must be within [0.3, 3], got '1e99'");
  EXPECT_EQ(message({"--palm-width", "0.1"}), "--palm-width must be within [0.3, 3], got '0.1'");
  EXPECT_EQ(message({"--thickness", "0"}), "--thickness must be positive");
  EXPECT_EQ(message({"--finger-length", "1,1,1e99,1,1"}),
            "--finger-length must be within [0.3, 3], got '1e99'");
  EXPECT_EQ(message({"--start-stamp", "1e99"}),
            "--start-stamp must be at most 4000000000 (2096; a bag stamp's seconds are 32 bits)");
  EXPECT_EQ(message({"--preview", "sheet.xyz"}),
            "--preview sheet.xyz: not an image file name OpenCV can write (use .png or .jpg)");
  EXPECT_EQ(message({"--out", "y.bag"}), "--out is given twice");
  EXPECT_EQ(message({"--gt-csv", "--quiet"}), "--gt-csv needs a value");
  // An empty value was taken as the default (no ground-truth CSV, the model's own shape).
  EXPECT_EQ(message({"--gt-csv", ""}), "--gt-csv needs a value, got an empty one");
  EXPECT_EQ(message({"--model", ""}), "--model needs a value, got an empty one");
  EXPECT_EQ(message({"--rig", ""}), "--rig needs a value, got an empty one");
  EXPECT_EQ(message({"--config-dir", ""}), "--config-dir needs a value, got an empty one");
  EXPECT_EQ(message({"--hand-scale", "3", "--palm-width", "0.3", "--preview", "p.png"}),
            "no error");
  EXPECT_EQ(message({"--hand", "auto"}), "--hand expects left or right, got 'auto'");
  EXPECT_EQ(
      parseRenderBagArguments({"--sequence", "pinch", "--out", "x.bag", "--hand", "left"}).hand,
      Handedness::kLeft);
}

TEST_F(RenderBagTool, RendersAStudioRoomWithTheHandsMasks) {
  // The office (portraits, a head, wooden props) and the tracked hand's pixels per camera: the
  // bag of room_graph.test.
  const ToolRun room = renderBag(
      "--sequence pinch --frames 12 --room office --hand-masks --quiet "
      "--out '" +
      path("office.bag") + "'");
  ASSERT_EQ(room.status, 0) << room.err;
  const ToolRun clean =
      renderBag("--sequence pinch --frames 12 --quiet --out '" + path("clean.bag") + "'");
  ASSERT_EQ(clean.status, 0) << clean.err;
  BagReader office_reader(path("office.bag")), clean_reader(path("clean.bag"));
  FrameSet office_set, clean_set;
  ASSERT_TRUE(office_reader.next(&office_set));
  ASSERT_TRUE(clean_reader.next(&clean_set));
  ASSERT_EQ(office_set.images.size(), clean_set.images.size());
  // The room is in the images (the empty studio's first frame differs everywhere it shows).
  EXPECT_GT(cv::norm(office_set.images[0].rgb, clean_set.images[0].rgb, cv::NORM_L1) /
                office_set.images[0].rgb.total(),
            20.0);
  rosbag::Bag bag(path("office.bag"));
  std::map<std::string, std::vector<int>> hand_pixels;  // per camera, per frame
  for (const rosbag::MessageInstance& m : rosbag::View(bag)) {
    if (m.getTopic().find("/hand_mask") == std::string::npos) continue;
    const auto mask = m.instantiate<sensor_msgs::Image>();
    ASSERT_TRUE(mask);
    EXPECT_EQ(mask->encoding, "mono8");
    EXPECT_EQ(mask->width, 320u);
    EXPECT_EQ(mask->height, 240u);
    EXPECT_EQ(m.getTime(), mask->header.stamp);
    hand_pixels[m.getTopic()].push_back(static_cast<int>(
        std::count_if(mask->data.begin(), mask->data.end(), [](uint8_t v) { return v != 0; })));
  }
  ASSERT_EQ(hand_pixels.size(), 5u);
  int with_hand = 0;
  for (const auto& [topic, counts] : hand_pixels) {
    ASSERT_EQ(counts.size(), 12u) << topic;
    for (int k = 0; k < 10; ++k) EXPECT_EQ(counts[k], 0) << topic << " frame " << k;
    with_hand += counts[10] > 200;
  }
  EXPECT_GE(with_hand, 4);  // the hand is in (almost) every view once it has come in
}

TEST_F(RenderBagTool, RendersAnotherHandWithABareForearm) {
  // The same motion on the default hand and on `stocky` with a bare forearm: the same poses, other
  // fingertips (the ground truth follows the shaped hand), and the summary names the hand.
  const std::string common = "--sequence pinch --frames 12 --quiet --out ";
  ASSERT_EQ(renderBag(common + "'" + path("d.bag") + "'").status, 0);
  const ToolRun run = renderBag(common + "'" + path("s.bag") + "' --shape stocky --bare-forearm");
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.err.find("pinch on the hand 'stocky' (bare forearm)"), std::string::npos)
      << run.err;
  const TrackingCsv d = readTrackingCsv(path("d.gt.csv"));
  const TrackingCsv s = readTrackingCsv(path("s.gt.csv"));
  ASSERT_EQ(d.rows.size(), 2u);
  ASSERT_EQ(s.rows.size(), 2u);
  EXPECT_EQ(d.rows[1].parameters, s.rows[1].parameters);
  // stocky's fingers are 13 % shorter: the middle fingertip is centimetres closer to the wrist.
  const Eigen::Vector3d wrist = d.rows[1].parameters.head<3>();
  EXPECT_LT((s.rows[1].fingertips[2] - wrist).norm(),
            (d.rows[1].fingertips[2] - wrist).norm() - 0.01);
}

// --empty-frames: the hand in view from the first frame (a still scene, room_graph_still.test),
// or after another number of empty frames; the ground truth follows.
TEST_F(RenderBagTool, TheEmptyFramesBeforeTheHandAreAnOption) {
  const std::string common = "--sequence pinch --frames 6 --quiet --out ";
  ASSERT_EQ(renderBag(common + "'" + path("e0.bag") + "' --empty-frames 0").status, 0);
  ASSERT_EQ(renderBag(common + "'" + path("e3.bag") + "' --empty-frames 3").status, 0);
  const TrackingCsv none = readTrackingCsv(path("e0.gt.csv"));
  const TrackingCsv three = readTrackingCsv(path("e3.gt.csv"));
  ASSERT_EQ(none.rows.size(), 6u);
  ASSERT_EQ(three.rows.size(), 3u);
  // The motion runs from the first frame either way (the empty frames hide its first ones): the
  // same frame has the same pose and stamp, and the hand is there from the first frame or the
  // fourth.
  EXPECT_NEAR(none.rows[0].stamp, 1400000000.0, 1e-6);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(none.rows[3 + k].parameters, three.rows[k].parameters) << k;
    EXPECT_NEAR(none.rows[3 + k].stamp, three.rows[k].stamp, 1e-6) << k;
  }
  BagReader reader(path("e0.bag"));
  int sets = 0;
  for (FrameSet set; reader.next(&set);) ++sets;
  EXPECT_EQ(sets, 6);
  EXPECT_EQ(parseRenderBagArguments({"--sequence", "pinch", "--out", "x.bag"}).empty_frames, -1);
  EXPECT_THROW(
      parseRenderBagArguments({"--sequence", "pinch", "--out", "x.bag", "--empty-frames", "-1"}),
      UsageError);
}

TEST_F(RenderBagTool, AFailureHalfWayLeavesNoOutputAndTheOldFilesUntouched) {
  write("p.bag", "an older bag\n");
  const auto files_before = std::distance(fs::directory_iterator(dir_), fs::directory_iterator());
  // The preview (frame 6 of 8) cannot be written: the .pgm writer takes grey images only. (An
  // extension without a writer, .xyz, is refused before the rendering.)
  // Without --overwrite the older bag is refused before anything is rendered.
  const ToolRun refused =
      renderBag("--sequence pinch --frames 8 --out '" + path("p.bag") + "' --quiet");
  EXPECT_EQ(refused.status, 1);
  EXPECT_EQ(refused.err, "render_bag: error: --out " + path("p.bag") +
                             " exists; it is not replaced (--overwrite replaces it, or choose "
                             "another name)\n");
  const ToolRun run =
      renderBag("--sequence pinch --frames 8 --out '" + path("p.bag") + "' --preview '" +
                path("p.pgm") + "' --preview-frame 6 --quiet --overwrite");
  EXPECT_EQ(run.status, 1);
  EXPECT_NE(run.err.find("render_bag: error: --preview " + path("p.pgm") +
                         ": cannot write the contact sheet"),
            std::string::npos)
      << run.err;
  EXPECT_EQ(readAll(path("p.bag")), "an older bag\n");
  EXPECT_FALSE(fs::exists(path("p.gt.csv")));
  EXPECT_FALSE(fs::exists(path("p.pgm")));
  // Only stdout.txt and stderr.txt of the run are new.
  EXPECT_LE(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()),
            files_before + 2);
}

// Ctrl-C or SIGTERM stops render_bag between two frames: exit status 130, its temporary files
// removed, an older file at --out left as it was.
TEST_F(RenderBagTool, AnInterruptedRunLeavesNoTemporaryFilesAndTheOldFilesUntouched) {
  write("i.bag", "an older bag\n");
  // 5000 frames take minutes; SIGTERM comes after 4 s, in the rendering loop.
  const ToolRun run =
      runTool(std::string("timeout --preserve-status -s TERM 4 '") + SAG_BIN_DIR +
              "/render_bag' --config-dir '" + kConfig + "' --sequence pinch --frames 5000 --out '" +
              path("i.bag") + "' --quiet --overwrite");
  EXPECT_EQ(run.status, 130) << run.err;
  EXPECT_NE(run.err.find("interrupted; nothing was written"), std::string::npos) << run.err;
  EXPECT_EQ(readAll(path("i.bag")), "an older bag\n");
  EXPECT_FALSE(fs::exists(path("i.gt.csv")));
  for (const auto& entry : fs::directory_iterator(dir_)) {
    EXPECT_EQ(entry.path().filename().string().find("tmp"), std::string::npos) << entry.path();
  }
}
