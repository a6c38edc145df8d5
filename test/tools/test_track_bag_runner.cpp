// The track_bag loop with a stand-in tracking call: command line, sets in, CSV rows, progress and
// summary out.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>
#include <sstream>

#include "sag_hand_tracker/apps/csv.h"
#include "sag_hand_tracker/apps/track_runner.h"
#include "sag_hand_tracker/ros/bag_output.h"

using namespace sag_hand_tracker;
namespace fs = std::filesystem;

namespace {

std::vector<std::string> names26() {
  std::vector<std::string> names;
  for (int i = 0; i < kNumDof; ++i) names.push_back("p" + std::to_string(i));
  return names;
}

Camera smallCamera(int id) {
  Camera camera;
  camera.name = "cam" + std::to_string(id);
  camera.width = 8;
  camera.height = 6;
  camera.K << 10, 0, 4, 0, 10, 3, 0, 0, 1;
  Eigen::Isometry3d root_to_optical = Eigen::Isometry3d::Identity();
  root_to_optical.translation() = Eigen::Vector3d(0.3 * id, 0.0, -1.0);
  camera.world_to_camera = root_to_optical.inverse();
  return camera;
}

ros::Time frameTime(int frame) { return ros::Time(50, 0) + ros::Duration(0.04 * frame); }

class TrackBagRun : public ::testing::Test {
 protected:
  void SetUp() override {
    std::random_device random;
    dir_ = fs::temp_directory_path() / ("sag_track_bag_test_" + std::to_string(random()));
    fs::create_directories(dir_);
    // 6 frames of 3 cameras; cam2 misses frame 4. The red channel of every pixel is the frame
    // number times 10, the green the camera id.
    std::vector<Camera> cameras{smallCamera(0), smallCamera(1), smallCamera(2)};
    BagWriter writer(path("in.bag"));
    writer.writeStaticTransforms("world", cameras, frameTime(0));
    for (int frame = 0; frame < 6; ++frame) {
      for (int id = 0; id < 3; ++id) {
        if (frame == 4 && id == 2) continue;
        cv::Mat rgb(6, 8, CV_8UC3, cv::Scalar(10 * frame, id, 0));
        writer.writeCameraImage(cameras[id], rgb, frameTime(frame), "bgr8");
      }
    }
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  fs::path dir_;
};

// Frames 0-1 are background; then a pose whose x is the red value of the first image / 1000,
// no pose for the incomplete set, frame 3 lost and frame 5 restarted.
ProcessedFrame standIn(const FrameSet& set) {
  ProcessedFrame processed;
  const int frame = static_cast<int>(std::lround((set.stamp() - 50.0) / 0.04));
  if (frame < 2) {
    processed.background = true;
    return processed;
  }
  FrameResult& result = processed.result;
  result.stamp = set.stamp();
  result.num_cameras = static_cast<int>(set.images.size());
  processed.image_gaussians = 7;
  processed.segmentation_seconds = 0.001;
  processed.tracking_seconds = 0.002;
  if (set.images.size() < 3) {
    result.status = TrackStatus::kWaiting;
    return processed;
  }
  result.has_pose = true;
  result.status = frame == 3 ? TrackStatus::kLost : TrackStatus::kTracking;
  result.restarted = frame == 5;
  result.pose.translation.x() = set.images[0].rgb.at<cv::Vec3b>(0, 0)[0] / 1000.0;
  result.pose.joints[19] = 0.25;
  for (int finger = 0; finger < kNumFingers; ++finger) {
    result.fingertips[finger] =
        Eigen::Vector3d(finger, set.images[2].rgb.at<cv::Vec3b>(0, 0)[1], 0);
  }
  result.energy.total = 0.5 + frame;
  return processed;
}

}  // namespace

TEST(TrackBagArguments, TrackBagParsesEveryOption) {
  const TrackBagOptions options = parseTrackBagArguments({"--bag",
                                                          "in.bag",
                                                          "--out",
                                                          "out.csv",
                                                          "--model",
                                                          "sog",
                                                          "--iterations",
                                                          "25",
                                                          "--cameras",
                                                          "0,2,4",
                                                          "--background-frames",
                                                          "0",
                                                          "--hand",
                                                          "left",
                                                          "--step-control",
                                                          "fixed",
                                                          "--root-frame",
                                                          "table",
                                                          "--room-cues",
                                                          "--quiet"});
  EXPECT_EQ(options.bag, "in.bag");
  EXPECT_EQ(options.out, "out.csv");
  EXPECT_EQ(options.model, "sog");
  EXPECT_EQ(options.iterations, 25);
  EXPECT_EQ(options.cameras, (std::vector<int>{0, 2, 4}));
  EXPECT_EQ(options.background_frames, 0);
  EXPECT_EQ(options.hand, Handedness::kLeft);
  EXPECT_EQ(options.step_control, "fixed");
  EXPECT_EQ(options.root_frame, "table");
  EXPECT_EQ(options.room_cues, std::optional<bool>(true));
  EXPECT_TRUE(trackBagPipelineParams(options).segmentation.room.enabled);
  EXPECT_TRUE(options.quiet);

  const TrackBagOptions defaults = parseTrackBagArguments({"--out", "o.csv", "--bag", "b.bag"});
  EXPECT_EQ(defaults.model, "sag");
  EXPECT_EQ(defaults.iterations, OptimizerParams().iterations);
  EXPECT_EQ(defaults.background_frames, 10);
  EXPECT_EQ(defaults.hand, Handedness::kRight);
  EXPECT_FALSE(defaults.hand_auto);
  EXPECT_TRUE(
      parseTrackBagArguments({"--out", "o.csv", "--bag", "b.bag", "--hand", "auto"}).hand_auto);
  EXPECT_TRUE(defaults.cameras.empty());
  EXPECT_FALSE(defaults.quiet);
  EXPECT_FALSE(defaults.room_cues.has_value());
  EXPECT_FALSE(trackBagPipelineParams(defaults).segmentation.room.enabled);  // with a plate
  // Without a plate (the skin gate) the room cues are on unless --no-room-cues says otherwise.
  const TrackBagOptions skin =
      parseTrackBagArguments({"--out", "o.csv", "--bag", "b.bag", "--background-frames", "0"});
  EXPECT_TRUE(trackBagPipelineParams(skin).segmentation.room.enabled);
  const TrackBagOptions skin_only = parseTrackBagArguments(
      {"--out", "o.csv", "--bag", "b.bag", "--background-frames", "0", "--no-room-cues"});
  EXPECT_FALSE(trackBagPipelineParams(skin_only).segmentation.room.enabled);
  EXPECT_TRUE(parseTrackBagArguments({"--help"}).help);
}

TEST(TrackBagArguments, TrackBagRejectsBadArguments) {
  auto message = [](const std::vector<std::string>& args) -> std::string {
    try {
      parseTrackBagArguments(args);
    } catch (const UsageError& error) {
      return error.what();
    }
    return "no error";
  };
  const std::vector<std::string> base{"--bag", "b.bag", "--out", "o.csv"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = base;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  EXPECT_EQ(message({"--out", "o.csv"}), "--bag is required");
  EXPECT_EQ(message({"--bag", "b.bag"}), "--out is required");
  EXPECT_EQ(message(with({"--iterations", "0"})), "--iterations expects an integer >= 1, got '0'");
  EXPECT_EQ(message(with({"--iterations", "ten"})),
            "--iterations expects an integer >= 1, got 'ten'");
  EXPECT_EQ(message(with({"--cameras", "0,x"})), "--cameras expects an integer >= 0, got 'x'");
  EXPECT_EQ(message(with({"--cameras", "1,1"})), "--cameras lists camera 1 twice");
  // Session 30: a value above the limit was refused as not ">= 1"; leading white space was
  // skipped.
  EXPECT_EQ(message(with({"--iterations", "1000001"})),
            "--iterations expects an integer of at most 1000000, got '1000001'");
  EXPECT_EQ(message(with({"--cameras", "0,1000001"})),
            "--cameras expects an integer of at most 1000000, got '1000001'");
  EXPECT_EQ(message(with({"--iterations", " 10"})),
            "--iterations expects an integer >= 1, got ' 10'");
  EXPECT_EQ(message(with({"--stamp-tolerance", " 0.1"})),
            "--stamp-tolerance expects a number within [0, 1], got ' 0.1'");
  EXPECT_EQ(parseTrackBagArguments(with({"--iterations", "1000000"})).iterations, 1000000);
  EXPECT_EQ(message(with({"--cameras", "1,"})),
            "--cameras expects camera numbers like 0,2,4, got '1,'");
  EXPECT_EQ(message(with({"--hand", "both"})), "--hand expects left, right or auto, got 'both'");
  EXPECT_EQ(message(with({"--step-control", "newton"})),
            "--step-control expects rprop or fixed, got 'newton'");
  EXPECT_EQ(message(with({"--background-frames", "-1"})),
            "--background-frames expects an integer >= 0, got '-1'");
  EXPECT_EQ(message(with({"--model"})), "--model needs a value");
  EXPECT_EQ(message({"--bag", "--out", "o.csv"}), "--bag needs a value");
  // An explicitly empty value was taken as the default (--root-frame "": the bag's root).
  EXPECT_EQ(message(with({"--root-frame", ""})), "--root-frame needs a value, got an empty one");
  EXPECT_EQ(message(with({"--model", ""})), "--model needs a value, got an empty one");
  EXPECT_EQ(message({"--bag", "", "--out", "o.csv"}), "--bag needs a value, got an empty one");
  EXPECT_EQ(message(with({"--hand", ""})), "--hand needs a value, got an empty one");
  EXPECT_EQ(message(with({"--frobnicate"})), "unknown argument '--frobnicate'");
  EXPECT_EQ(message(with({"--bag", "other.bag"})), "--bag is given twice");
  EXPECT_EQ(message(with({"--iterations", "3", "--iterations", "4"})),
            "--iterations is given twice");
  EXPECT_EQ(message(with({"--quiet", "--quiet"})), "--quiet is given twice");
  EXPECT_NE(trackBagUsage().find("--background-frames N"), std::string::npos);
}

TEST_F(TrackBagRun, TrackBagWritesRowsAndCountsFrames) {
  BagReader reader(path("in.bag"));
  std::ostringstream progress_text;
  ProgressBar progress(progress_text, false);
  TrackBagSummary summary;
  {
    TrackingCsvWriter csv(path("out.csv"), names26(), /*status_column=*/true);
    summary = runTrackBag(reader, standIn, csv, &progress);
  }
  EXPECT_EQ(summary.frames, 6);
  EXPECT_EQ(summary.background_frames, 2);
  EXPECT_EQ(summary.tracked_frames, 2);  // the lost frame 3 is not tracked
  EXPECT_EQ(summary.waiting_frames, 1);
  EXPECT_EQ(summary.lost_frames, 1);
  EXPECT_EQ(summary.restarted_frames, 1);
  EXPECT_EQ(summary.incomplete_sets, 1);
  EXPECT_EQ(summary.image_gaussians, 28);
  EXPECT_NEAR(summary.segmentation_seconds, 0.004, 1e-12);
  EXPECT_NEAR(summary.tracking_seconds, 0.008, 1e-12);
  EXPECT_GT(summary.decode_seconds, 0.0);
  EXPECT_GT(summary.pipeline_seconds, 0.0);
  EXPECT_NEAR(summary.pipelineFps(), 4.0 / summary.pipeline_seconds, 1e-9);
  EXPECT_EQ(summary.cameras, (std::vector<std::string>{"cam0", "cam1", "cam2"}));
  EXPECT_FALSE(summary.interrupted);

  const TrackingCsv csv = readTrackingCsv(path("out.csv"));
  EXPECT_EQ(csv.parameter_names, names26());
  ASSERT_EQ(csv.rows.size(), 3u);
  const int frames[] = {2, 3, 5};
  const std::string statuses[] = {"tracked", "lost", "tracked"};
  for (int k = 0; k < 3; ++k) {
    const TrackingCsvRow& row = csv.rows[k];
    EXPECT_NEAR(row.stamp, frameTime(frames[k]).toSec(), 1e-6);
    EXPECT_NEAR(row.parameters[0], 10 * frames[k] / 1000.0, 1e-9);  // bgr8 read back as RGB
    EXPECT_NEAR(row.parameters[25], 0.25, 1e-9);
    EXPECT_NEAR(row.fingertips[3].x(), 3.0, 1e-9);
    EXPECT_NEAR(row.fingertips[3].y(), 2.0, 1e-9);  // the image of cam2
    EXPECT_NEAR(row.energy, 0.5 + frames[k], 1e-9);
    EXPECT_EQ(row.status, statuses[k]);
  }
  const std::string text = progress_text.str();
  EXPECT_NE(text.find("frame 1, 3 cameras, background"), std::string::npos) << text;
  EXPECT_NE(text.find("100% 6 frames"), std::string::npos) << text;

  const std::string report = formatSummary(summary);
  EXPECT_NE(report.find("frames:    6 (2 background, 2 tracked, 1 lost, 1 without a hand pose), 1 "
                        "with a camera missing"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find("cameras:   3 (cam0 cam1 cam2)"), std::string::npos) << report;
  EXPECT_NE(report.find("over 4 frames, decode excluded); per frame: segmentation 1.00 ms, "
                        "optimisation 2.00 ms"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find("lost in 1 frames, restarted in 1 frames"), std::string::npos) << report;
  EXPECT_NE(report.find("output:    3 rows (2 tracked or started, 1 lost) in " + path("out.csv")),
            std::string::npos)
      << report;
}

TEST_F(TrackBagRun, TrackBagStopsWhenInterrupted) {
  BagReader reader(path("in.bag"));
  std::atomic<bool> stop{false};
  int calls = 0;
  TrackingCsvWriter csv(path("out.csv"), names26());
  const TrackBagSummary summary = runTrackBag(
      reader,
      [&](const FrameSet& set) {
        if (++calls == 3) stop = true;
        return standIn(set);
      },
      csv, nullptr, &stop);
  EXPECT_TRUE(summary.interrupted);
  EXPECT_EQ(summary.frames, 3);
  EXPECT_EQ(readTrackingCsv(path("out.csv")).rows.size(), 1u);
  EXPECT_NE(formatSummary(summary).find("(interrupted)"), std::string::npos);
}

// Repeated stamps and stamps that leap forward are warnings of the summary, naming the first.
TEST(TrackBagOutput, TheSummaryNamesRepeatedStampsAndForwardLeaps) {
  TrackBagSummary summary;
  summary.frames = 4;
  summary.tracked_frames = 4;
  summary.reading.duplicate_stamps = 2;
  summary.reading.first_duplicate_stamp = "/cam1/image_raw frame 2 at 100.000000";
  summary.reading.forward_jumps = 3;
  summary.reading.first_forward_jump = "/cam0/image_raw frame 3 at 7300.080000 after 100.040000";
  const std::string report = formatSummary(summary);
  EXPECT_NE(report.find("  warning:   2 images with the stamp of an earlier image of their camera "
                        "(first: /cam1/image_raw frame 2 at 100.000000); only the first image of a "
                        "stamp is used\n"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find("  warning:   3 images with stamps more than 10 s after their camera's "
                        "previous image (first: /cam0/image_raw frame 3 at 7300.080000 after "
                        "100.040000); a clock set forward or a paused recording, read as the "
                        "next frame\n"),
            std::string::npos)
      << report;
  EXPECT_EQ(formatSummary(TrackBagSummary()).find("warning"), std::string::npos);
}

// The model's size at the end (TrackerParams::size_step) is in the summary when it moved.
TEST(TrackBagOutput, TheSummarySaysWhenTheModelTookAnotherSize) {
  TrackBagSummary summary;
  summary.frames = 4;
  summary.tracked_frames = 4;
  EXPECT_EQ(formatSummary(summary).find("model:"), std::string::npos);
  summary.model_size = 1.0824;
  EXPECT_NE(formatSummary(summary).find("  model:     scaled by 1.082 to the hand's size in the "
                                        "images (the size it ended with)\n"),
            std::string::npos)
      << formatSummary(summary);
}

// The partial rows of an interrupted run never replace an earlier output.
TEST(TrackBagOutput, AnInterruptedRunReplacesNoEarlierOutput) {
  TrackBagSummary finished;
  finished.tracked_frames = 5;
  EXPECT_TRUE(commitsTrackCsv(finished, 5));
  finished.out_existed = true;
  EXPECT_TRUE(commitsTrackCsv(finished, 5));  // a finished run replaces it, as documented
  finished.tracked_frames = 0;
  EXPECT_FALSE(commitsTrackCsv(finished, 0));

  TrackBagSummary interrupted;
  interrupted.interrupted = true;
  interrupted.tracked_frames = 3;
  EXPECT_TRUE(commitsTrackCsv(interrupted, 3));  // nothing was there: the rows so far
  EXPECT_FALSE(commitsTrackCsv(interrupted, 0));
  interrupted.out_existed = true;
  interrupted.csv = "old.csv";
  EXPECT_FALSE(commitsTrackCsv(interrupted, 3));
  EXPECT_NE(formatSummary(interrupted).find("the existing old.csv was left as it was"),
            std::string::npos)
      << formatSummary(interrupted);
}

TEST_F(TrackBagRun, TrackBagPassesTrackingErrorsOn) {
  BagReader reader(path("in.bag"));
  TrackingCsvWriter csv(path("out.csv"), names26());
  EXPECT_THROW(
      runTrackBag(
          reader, [](const FrameSet&) -> ProcessedFrame { throw InputError("bad"); }, csv, nullptr),
      InputError);
}

// A lost frame without a pose (after a clock jump back in bag time and stamps) has no CSV row:
// the summary counted it among the rows ("29 rows ... 12 lost" for a CSV of 28 rows, 11 lost).
TEST_F(TrackBagRun, TheSummaryCountsTheRowsTheCsvHas) {
  BagReader reader(path("in.bag"));
  TrackBagSummary summary;
  {
    TrackingCsvWriter csv(path("out.csv"), names26(), /*status_column=*/true);
    summary = runTrackBag(
        reader,
        [](const FrameSet& set) {
          ProcessedFrame processed = standIn(set);
          // The incomplete set (frame 4): lost, and no pose to write.
          if (processed.result.status == TrackStatus::kWaiting) {
            processed.result.status = TrackStatus::kLost;
          }
          return processed;
        },
        csv, nullptr);
  }
  EXPECT_EQ(summary.lost_frames, 2);
  EXPECT_EQ(summary.lost_rows, 1);
  const TrackingCsv csv = readTrackingCsv(path("out.csv"));
  ASSERT_EQ(csv.rows.size(), 3u);
  const std::string report = formatSummary(summary);
  EXPECT_NE(report.find("frames:    6 (2 background, 2 tracked, 2 lost, 0 without a hand pose)"),
            std::string::npos)
      << report;
  EXPECT_NE(report.find("output:    3 rows (2 tracked or started, 1 lost) in "), std::string::npos)
      << report;
}
