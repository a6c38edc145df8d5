#include <gtest/gtest.h>

#include "test_support/temp_files.h"

#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <random>

#include "sag_hand_tracker/capture/capture.h"
#include "sag_hand_tracker/util/types.h"

using namespace sag_hand_tracker;
namespace fs = std::filesystem;

namespace {

class CaptureFiles : public sag_test::TempDirTest {
 protected:
  // A folder of `count` BGR images "<i>.png" (zero-padded), image i filled with (B, G, R) =
  // (0, 10 * i, 255).
  std::string makeFolder(const std::string& name, int count, cv::Size size = {16, 12}) const {
    const fs::path folder = dir_ / name;
    fs::create_directories(folder);
    for (int i = 0; i < count; ++i) {
      char file[32];
      std::snprintf(file, sizeof(file), "%03d.png", i);
      cv::imwrite((folder / file).string(), cv::Mat(size, CV_8UC3, cv::Scalar(0, 10 * i, 255)));
    }
    return folder.string();
  }
};

// Green channel of pixel (0, 0) of an RGB frame: the image index * 10 in makeFolder's images.
int greenOf(const cv::Mat& rgb) { return rgb.at<cv::Vec3b>(0, 0)[1]; }

// A source whose grab results are scripted; counts its calls.
class ScriptedSource : public FrameSource {
 public:
  explicit ScriptedSource(std::vector<GrabResult> script, int* grabs)
      : FrameSource(parseSourceSpec("/dev/video7")), script_(std::move(script)), grabs_(grabs) {}
  GrabResult grab() override {
    const GrabResult result = script_.at(static_cast<std::size_t>(*grabs_));
    ++*grabs_;
    if (result == GrabResult::kFailed) problem_ = "the device delivered no frame";
    return result;
  }
  bool retrieve(cv::Mat* bgr) override {
    *bgr = cv::Mat(4, 4, CV_8UC3, cv::Scalar(1, 2, 3));
    return true;
  }

 private:
  std::vector<GrabResult> script_;
  int* grabs_;
};

}  // namespace

TEST(SourceSpec, ParsesDevicesFilesAndFolders) {
  SourceSpec spec = parseSourceSpec("0");
  EXPECT_EQ(spec.kind, SourceKind::kDevice);
  EXPECT_EQ(spec.device_index, 0);
  EXPECT_EQ(describeSource(spec), "V4L2 device 0");

  spec = parseSourceSpec(" 12 ");
  EXPECT_EQ(spec.kind, SourceKind::kDevice);
  EXPECT_EQ(spec.device_index, 12);

  spec = parseSourceSpec("/dev/video2");
  EXPECT_EQ(spec.kind, SourceKind::kDevice);
  EXPECT_EQ(spec.device_index, -1);
  EXPECT_EQ(spec.path, "/dev/video2");
  EXPECT_EQ(describeSource(spec), "V4L2 device /dev/video2");

  spec = parseSourceSpec("dir:/data/cam0");
  EXPECT_EQ(spec.kind, SourceKind::kImageFolder);
  EXPECT_EQ(spec.path, "/data/cam0");
  EXPECT_EQ(describeSource(spec), "image folder '/data/cam0'");

  spec = parseSourceSpec("recordings/cam1.avi");
  EXPECT_EQ(spec.kind, SourceKind::kVideoFile);
  EXPECT_EQ(spec.path, "recordings/cam1.avi");
  EXPECT_EQ(spec.text, "recordings/cam1.avi");
  EXPECT_EQ(describeSource(spec), "video file 'recordings/cam1.avi'");

  spec = parseSourceSpec("-1");  // not a device index
  EXPECT_EQ(spec.kind, SourceKind::kVideoFile);
}

TEST(SourceSpec, RejectsEmptySources) {
  EXPECT_NE(sag_test::inputErrorOf([] { parseSourceSpec(""); }).find("empty camera source"),
            std::string::npos);
  EXPECT_NE(sag_test::inputErrorOf([] { parseSourceSpec("  "); }).find("empty camera source"),
            std::string::npos);
  EXPECT_NE(sag_test::inputErrorOf([] { parseSourceSpec("dir: "); }).find("no folder after 'dir:'"),
            std::string::npos);
}

TEST(ImageFiles, KnowsImageExtensions) {
  EXPECT_TRUE(isImageFileName("a.png"));
  EXPECT_TRUE(isImageFileName("a.JPG"));
  EXPECT_TRUE(isImageFileName("/x/y/frame.jpeg"));
  EXPECT_TRUE(isImageFileName("f.tiff"));
  EXPECT_FALSE(isImageFileName("notes.txt"));
  EXPECT_FALSE(isImageFileName("png"));
  EXPECT_FALSE(isImageFileName("video.avi"));
}

TEST_F(CaptureFiles, ListsImagesSortedAndSkipsOthers) {
  const fs::path folder = dir_ / "images";
  fs::create_directories(folder / "sub.png");  // a folder, not an image
  for (const char* name : {"b.png", "a10.jpg", "a2.jpg", "readme.txt", "C.bmp"}) {
    std::ofstream(folder / name) << "x";
  }
  const std::vector<std::string> files = listImageFiles(folder.string());
  ASSERT_EQ(files.size(), 4u);
  EXPECT_EQ(files[0], (folder / "C.bmp").string());  // byte-wise: upper case first
  EXPECT_EQ(files[1], (folder / "a10.jpg").string());
  EXPECT_EQ(files[2], (folder / "a2.jpg").string());
  EXPECT_EQ(files[3], (folder / "b.png").string());

  EXPECT_TRUE(listImageFiles(makeFolder("empty", 0)).empty());
  EXPECT_NE(sag_test::inputErrorOf([&] {
              listImageFiles(path("missing"));
            }).find("'" + path("missing") + "' does not exist"),
            std::string::npos);
  EXPECT_NE(sag_test::inputErrorOf([&] {
              listImageFiles((folder / "b.png").string());
            }).find("is not a folder"),
            std::string::npos);
}

TEST(FitFrame, ResizesOnlyWhenTheSizeDiffers) {
  const cv::Mat frame(48, 64, CV_8UC3, cv::Scalar(10, 20, 30));
  const cv::Mat same = fitFrame(frame, 64, 48);
  EXPECT_EQ(same.data, frame.data);  // shared, not copied
  const cv::Mat keep = fitFrame(frame, 0, 0);
  EXPECT_EQ(keep.data, frame.data);

  const cv::Mat smaller = fitFrame(frame, 32, 24);
  EXPECT_EQ(smaller.cols, 32);
  EXPECT_EQ(smaller.rows, 24);
  EXPECT_EQ(smaller.at<cv::Vec3b>(5, 5), cv::Vec3b(10, 20, 30));
  const cv::Mat larger = fitFrame(frame, 100, 0);
  EXPECT_EQ(larger.cols, 100);
  EXPECT_EQ(larger.rows, 48);
  EXPECT_EQ(larger.type(), CV_8UC3);
}

TEST(ToBgr8, ConvertsGreyColourAndDeepImages) {
  const cv::Mat grey(2, 3, CV_8UC1, cv::Scalar(77));
  cv::Mat bgr = toBgr8(grey);
  EXPECT_EQ(bgr.type(), CV_8UC3);
  EXPECT_EQ(bgr.at<cv::Vec3b>(1, 2), cv::Vec3b(77, 77, 77));

  const cv::Mat bgra(2, 3, CV_8UC4, cv::Scalar(1, 2, 3, 4));
  EXPECT_EQ(toBgr8(bgra).at<cv::Vec3b>(0, 0), cv::Vec3b(1, 2, 3));

  const cv::Mat deep(2, 3, CV_16UC3, cv::Scalar(256 * 10, 256 * 20, 256 * 30));
  EXPECT_EQ(toBgr8(deep).at<cv::Vec3b>(0, 0), cv::Vec3b(10, 20, 30));

  const cv::Mat colour(2, 3, CV_8UC3);
  EXPECT_EQ(toBgr8(colour).data, colour.data);
}

TEST_F(CaptureFiles, OpeningReportsTheSource) {
  SourceOptions options;
  EXPECT_EQ(sag_test::inputErrorOf(
                [&] { openFrameSource(parseSourceSpec("dir:" + path("nope")), options); }),
            "image folder '" + path("nope") + "' does not exist");
  const std::string empty = makeFolder("empty", 0);
  EXPECT_NE(sag_test::inputErrorOf([&] {
              openFrameSource(parseSourceSpec("dir:" + empty), options);
            }).find("image folder '" + empty + "' holds no image files"),
            std::string::npos);
  EXPECT_EQ(
      sag_test::inputErrorOf([&] { openFrameSource(parseSourceSpec(path("none.avi")), options); }),
      "video file '" + path("none.avi") + "' does not exist");
  EXPECT_EQ(sag_test::inputErrorOf(
                [&] { openFrameSource(parseSourceSpec("/dev/video_sag_none"), options); }),
            "V4L2 device /dev/video_sag_none does not exist");
  std::ofstream(path("garbage.avi")) << "not a video";
  EXPECT_NE(sag_test::inputErrorOf([&] {
              openFrameSource(parseSourceSpec(path("garbage.avi")), options);
            }).find("cannot be opened"),
            std::string::npos);
}

TEST_F(CaptureFiles, FolderIsReadInOrderAndFinishesWithoutLoop) {
  const std::string folder = makeFolder("cam", 3);
  SourceOptions options;
  options.loop = false;
  auto source = openFrameSource(parseSourceSpec("dir:" + folder), options);
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(source->grab(), GrabResult::kOk);
    cv::Mat bgr;
    ASSERT_TRUE(source->retrieve(&bgr));
    EXPECT_EQ(bgr.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 10 * i, 255)) << "image " << i;
  }
  EXPECT_EQ(source->grab(), GrabResult::kFinished);
  EXPECT_EQ(source->problem(), "all 3 images read (loop is off)");
  EXPECT_EQ(source->grab(), GrabResult::kFinished);
}

TEST_F(CaptureFiles, FolderLoops) {
  const std::string folder = makeFolder("cam", 2);
  SourceOptions options;
  options.loop = true;
  auto source = openFrameSource(parseSourceSpec("dir:" + folder), options);
  std::vector<int> greens;
  for (int i = 0; i < 5; ++i) {
    ASSERT_EQ(source->grab(), GrabResult::kOk);
    cv::Mat bgr;
    ASSERT_TRUE(source->retrieve(&bgr));
    greens.push_back(bgr.at<cv::Vec3b>(0, 0)[1]);
  }
  EXPECT_EQ(greens, (std::vector<int>{0, 10, 0, 10, 0}));
}

TEST_F(CaptureFiles, UnreadableImageIsNamed) {
  const std::string folder = makeFolder("cam", 1);
  std::ofstream(fs::path(folder) / "001.png") << "not a png";
  auto source = openFrameSource(parseSourceSpec("dir:" + folder), SourceOptions{});
  cv::Mat bgr;
  ASSERT_EQ(source->grab(), GrabResult::kOk);
  EXPECT_TRUE(source->retrieve(&bgr));
  ASSERT_EQ(source->grab(), GrabResult::kOk);
  EXPECT_FALSE(source->retrieve(&bgr));
  EXPECT_EQ(source->problem(), "cannot read the image '" + folder + "/001.png'");
}

TEST_F(CaptureFiles, VideoFileIsReadAndLooped) {
  const std::string video = path("clip.avi");
  {
    cv::VideoWriter writer(video, cv::CAP_OPENCV_MJPEG, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'),
                           10.0, cv::Size(32, 24));
    ASSERT_TRUE(writer.isOpened()) << "OpenCV's own MJPEG writer is not available";
    for (int i = 0; i < 4; ++i) writer.write(cv::Mat(24, 32, CV_8UC3, cv::Scalar(0, 60 * i, 200)));
  }
  auto readGreens = [&](bool loop, int grabs, GrabResult* last) {
    SourceOptions options;
    options.loop = loop;
    auto source = openFrameSource(parseSourceSpec(video), options);
    std::vector<int> greens;
    for (int i = 0; i < grabs; ++i) {
      *last = source->grab();
      if (*last != GrabResult::kOk) break;
      cv::Mat bgr;
      EXPECT_TRUE(source->retrieve(&bgr));
      EXPECT_EQ(bgr.type(), CV_8UC3);
      EXPECT_EQ(bgr.cols, 32);
      // MJPEG is lossy: round to the written steps of 60.
      greens.push_back(static_cast<int>(std::lround(bgr.at<cv::Vec3b>(12, 16)[1] / 60.0)));
    }
    return greens;
  };
  GrabResult last = GrabResult::kOk;
  EXPECT_EQ(readGreens(false, 10, &last), (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(last, GrabResult::kFinished);
  EXPECT_EQ(readGreens(true, 6, &last), (std::vector<int>{0, 1, 2, 3, 0, 1}));
  EXPECT_EQ(last, GrabResult::kOk);
}

TEST_F(CaptureFiles, MultiCaptureCarriesOnWithoutFinishedAndMissingCameras) {
  SourceOptions options;
  std::vector<std::unique_ptr<FrameSource>> sources;
  sources.push_back(openFrameSource(parseSourceSpec("dir:" + makeFolder("a", 2)), options));
  sources.push_back(nullptr);  // could not be opened
  sources.push_back(
      openFrameSource(parseSourceSpec("dir:" + makeFolder("b", 4, {20, 15})), options));
  MultiCapture capture({"cam0", "cam1", "cam2"}, std::move(sources), 16, 12, 3);
  EXPECT_EQ(capture.state(1), CameraState::kNotOpened);
  EXPECT_EQ(capture.runningCount(), 2);

  for (int set = 0; set < 4; ++set) {
    capture.grabAll();
    const std::vector<cv::Mat> frames = capture.retrieveAll();
    ASSERT_EQ(frames.size(), 3u);
    EXPECT_TRUE(frames[1].empty());
    ASSERT_FALSE(frames[2].empty());
    EXPECT_EQ(frames[2].size(), cv::Size(16, 12));                          // resized
    EXPECT_EQ(frames[2].at<cv::Vec3b>(3, 3), cv::Vec3b(255, 10 * set, 0));  // RGB order
    const std::vector<CaptureEvent> events = capture.takeEvents();
    if (set < 2) {
      ASSERT_FALSE(frames[0].empty());
      EXPECT_EQ(greenOf(frames[0]), 10 * set);
      EXPECT_EQ(frames[0].at<cv::Vec3b>(0, 0)[0], 255);
    } else {
      EXPECT_TRUE(frames[0].empty());
    }
    if (set == 0) {  // the size difference of cam2 is reported once
      ASSERT_EQ(events.size(), 1u);
      EXPECT_EQ(events[0].kind, CaptureEvent::Kind::kResized);
      EXPECT_EQ(events[0].camera, 2);
      EXPECT_NE(events[0].message.find("camera cam2 (image folder '"), std::string::npos);
      EXPECT_NE(events[0].message.find("delivers 20x15 frames; resizing them to 16x12"),
                std::string::npos);
    } else if (set == 2) {  // cam0's folder ran out: reported once
      ASSERT_EQ(events.size(), 1u);
      EXPECT_EQ(events[0].kind, CaptureEvent::Kind::kFinished);
      EXPECT_EQ(events[0].camera, 0);
      EXPECT_NE(events[0].message.find("camera cam0 (image folder '"), std::string::npos);
      EXPECT_NE(events[0].message.find("has no more frames: all 2 images read (loop is off)"),
                std::string::npos);
    } else {
      EXPECT_TRUE(events.empty());
    }
  }
  EXPECT_EQ(capture.state(0), CameraState::kFinished);
  EXPECT_EQ(capture.state(2), CameraState::kRunning);
  EXPECT_EQ(capture.runningCount(), 1);
}

TEST(MultiCapture, StopsACameraAfterConsecutiveFailures) {
  using R = GrabResult;
  int grabs = 0;
  std::vector<std::unique_ptr<FrameSource>> sources;
  // Two failures, a frame (resets the count), then three failures: stopped at the third.
  sources.push_back(std::make_unique<ScriptedSource>(
      std::vector<R>{R::kFailed, R::kFailed, R::kOk, R::kFailed, R::kFailed, R::kFailed}, &grabs));
  MultiCapture capture({"cam3"}, std::move(sources), 0, 0, 3);
  std::vector<std::vector<CaptureEvent::Kind>> kinds;
  std::vector<bool> got_frame;
  for (int set = 0; set < 8; ++set) {
    capture.grabAll();
    got_frame.push_back(!capture.retrieveAll()[0].empty());
    kinds.emplace_back();
    for (const CaptureEvent& event : capture.takeEvents()) {
      kinds.back().push_back(event.kind);
      if (event.kind == CaptureEvent::Kind::kStopped) {
        EXPECT_EQ(event.message,
                  "camera cam3 (V4L2 device /dev/video7) stopped: no frame in 3 consecutive "
                  "attempts (the device delivered no frame); the other cameras carry on");
      }
    }
  }
  using K = CaptureEvent::Kind;
  EXPECT_EQ(got_frame, (std::vector<bool>{false, false, true, false, false, false, false, false}));
  EXPECT_EQ(kinds[0], std::vector<K>{K::kReadFailed});
  EXPECT_EQ(kinds[2], std::vector<K>{});
  EXPECT_EQ(kinds[4], std::vector<K>{K::kReadFailed});
  EXPECT_EQ(kinds[5], (std::vector<K>{K::kReadFailed, K::kStopped}));
  EXPECT_TRUE(kinds[6].empty());
  EXPECT_EQ(grabs, 6);  // a stopped camera is no longer grabbed
  EXPECT_EQ(capture.state(0), CameraState::kStopped);
  EXPECT_EQ(capture.runningCount(), 0);
}

TEST(ScaleIntrinsics, MapsPixelCentresOfTheResizedImage) {
  ImageIntrinsics in;
  in.width = 640;
  in.height = 480;
  in.K = {500, 0, 319.5, 0, 510, 239.5, 0, 0, 1};
  in.P = {500, 0, 319.5, -25, 0, 510, 239.5, 0, 0, 0, 1, 0};
  const ImageIntrinsics out = scaleIntrinsics(in, 320, 240);
  EXPECT_EQ(out.width, 320);
  EXPECT_EQ(out.height, 240);
  // Halving: focal lengths halve, the centre of the image stays the centre ((w - 1) / 2).
  EXPECT_DOUBLE_EQ(out.K[0], 250.0);
  EXPECT_DOUBLE_EQ(out.K[4], 255.0);
  EXPECT_DOUBLE_EQ(out.K[2], 159.5);
  EXPECT_DOUBLE_EQ(out.K[5], 119.5);
  EXPECT_DOUBLE_EQ(out.K[8], 1.0);
  EXPECT_DOUBLE_EQ(out.P[0], 250.0);
  EXPECT_DOUBLE_EQ(out.P[2], 159.5);
  EXPECT_DOUBLE_EQ(out.P[3], -12.5);  // fx * Tx scales with fx
  EXPECT_DOUBLE_EQ(out.P[5], 255.0);
  EXPECT_DOUBLE_EQ(out.P[6], 119.5);
  EXPECT_DOUBLE_EQ(out.P[10], 1.0);

  // A point projected with the scaled K lands where cv::resize puts the pixel it fell on.
  const Eigen::Vector3d point(0.03, -0.02, 0.5);
  const auto project = [&](const std::array<double, 9>& K) {
    return Eigen::Vector2d(K[0] * point.x() / point.z() + K[2],
                           K[4] * point.y() / point.z() + K[5]);
  };
  const Eigen::Vector2d before = project(in.K);
  const Eigen::Vector2d after = project(scaleIntrinsics(in, 160, 360).K);
  EXPECT_NEAR(after.x(), (before.x() + 0.5) * 160.0 / 640.0 - 0.5, 1e-9);
  EXPECT_NEAR(after.y(), (before.y() + 0.5) * 360.0 / 480.0 - 0.5, 1e-9);

  // The same size is the identity; a round trip gives the input back.
  const ImageIntrinsics same = scaleIntrinsics(in, 640, 480);
  EXPECT_EQ(same.K, in.K);
  EXPECT_EQ(same.P, in.P);
  const ImageIntrinsics back = scaleIntrinsics(scaleIntrinsics(in, 200, 150), 640, 480);
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(back.K[i], in.K[i], 1e-9) << i;
  for (int i = 0; i < 12; ++i) EXPECT_NEAR(back.P[i], in.P[i], 1e-9) << i;
  EXPECT_THROW(scaleIntrinsics(in, 0, 240), std::invalid_argument);
  ImageIntrinsics empty;
  EXPECT_THROW(scaleIntrinsics(empty, 320, 240), std::invalid_argument);
}

TEST(ReopenSchedule, BacksOffUpToTheMaximum) {
  ReopenSchedule schedule({0.5, 3.0, 2.0});
  EXPECT_FALSE(schedule.due(100.0));  // not stopped
  schedule.start(10.0);
  EXPECT_FALSE(schedule.due(10.4));
  EXPECT_TRUE(schedule.due(10.5));
  schedule.failed(10.5);  // waits 1 s
  EXPECT_FALSE(schedule.due(11.4));
  EXPECT_TRUE(schedule.due(11.5));
  schedule.failed(11.5);  // 2 s
  EXPECT_FALSE(schedule.due(13.4));
  schedule.failed(13.5);  // 3 s (capped, not 4)
  EXPECT_DOUBLE_EQ(schedule.delay(), 3.0);
  schedule.failed(16.5);
  EXPECT_DOUBLE_EQ(schedule.delay(), 3.0);
  EXPECT_EQ(schedule.attempts(), 4);
  schedule.reset();
  EXPECT_FALSE(schedule.due(1000.0));
  schedule.start(20.0);
  EXPECT_TRUE(schedule.due(20.5));  // a new stop starts from the first delay again
  EXPECT_EQ(schedule.attempts(), 0);
}

TEST(MultiCapture, ReopensAStoppedCameraWithBackoff) {
  using R = GrabResult;
  using K = CaptureEvent::Kind;
  int grabs_first = 0;
  int grabs_second = 0;
  std::vector<std::unique_ptr<FrameSource>> sources;
  // The device delivers once, then fails twice: stopped (max_failures 2).
  sources.push_back(std::make_unique<ScriptedSource>(std::vector<R>{R::kOk, R::kFailed, R::kFailed},
                                                     &grabs_first));
  MultiCapture capture({"cam3"}, std::move(sources), 0, 0, 2);
  // The device comes back on the third open attempt.
  int opens = 0;
  capture.enableReopen({parseSourceSpec("/dev/video7")},
                       [&](const SourceSpec& spec) -> std::unique_ptr<FrameSource> {
                         EXPECT_EQ(spec.path, "/dev/video7");
                         if (++opens < 3)
                           throw InputError("V4L2 device /dev/video7 cannot be opened");
                         return std::make_unique<ScriptedSource>(std::vector<R>(40, R::kOk),
                                                                 &grabs_second);
                       },
                       {1.0, 4.0, 2.0});
  std::vector<std::pair<double, std::vector<K>>> log;
  std::vector<std::string> messages;
  int frames = 0;
  for (double now = 0.0; now <= 12.0; now += 0.25) {
    capture.reopenDue(now);
    capture.grabAll();
    if (!capture.retrieveAll()[0].empty()) ++frames;
    std::vector<K> kinds;
    for (const CaptureEvent& event : capture.takeEvents()) {
      kinds.push_back(event.kind);
      if (event.kind == K::kReopenFailed || event.kind == K::kReopened) {
        messages.push_back(event.message);
      }
    }
    if (!kinds.empty()) log.emplace_back(now, kinds);
  }
  // Stopped at 0.5 s; the schedule starts at 0.75 s: attempts at 1.75 (fails, wait 2 s), 3.75
  // (fails, wait 4 s), 7.75 (succeeds).
  ASSERT_EQ(log.size(), 5u);
  EXPECT_EQ(log[0], (std::pair<double, std::vector<K>>{0.25, {K::kReadFailed}}));
  EXPECT_EQ(log[1], (std::pair<double, std::vector<K>>{0.5, {K::kReadFailed, K::kStopped}}));
  EXPECT_EQ(log[2], (std::pair<double, std::vector<K>>{1.75, {K::kReopenFailed}}));
  EXPECT_EQ(log[3], (std::pair<double, std::vector<K>>{3.75, {K::kReopenFailed}}));
  EXPECT_EQ(log[4], (std::pair<double, std::vector<K>>{7.75, {K::kReopened}}));
  ASSERT_EQ(messages.size(), 3u);
  EXPECT_EQ(messages[0],
            "camera cam3 (V4L2 device /dev/video7): reopen attempt 1 failed (V4L2 device "
            "/dev/video7 cannot be opened); next attempt in 2.0 s");
  EXPECT_EQ(messages[2],
            "camera cam3 (V4L2 device /dev/video7) reopened after 3 attempts; it is grabbed again");
  EXPECT_EQ(opens, 3);
  EXPECT_EQ(grabs_first, 3);
  EXPECT_EQ(capture.state(0), CameraState::kRunning);
  // One frame before the stop, then one per cycle from 7.75 s to 12 s.
  EXPECT_EQ(grabs_second, 18);
  EXPECT_EQ(frames, 1 + 18);
}

TEST(MultiCapture, WithoutReopenAStoppedCameraStaysStoppedAndFinishedFilesAreNotReopened) {
  using R = GrabResult;
  int grabs = 0;
  int grabs_finished = 0;
  std::vector<std::unique_ptr<FrameSource>> sources;
  sources.push_back(std::make_unique<ScriptedSource>(std::vector<R>{R::kFailed}, &grabs));
  sources.push_back(
      std::make_unique<ScriptedSource>(std::vector<R>{R::kFinished}, &grabs_finished));
  MultiCapture capture({"cam0", "cam1"}, std::move(sources), 0, 0, 1);
  int opens = 0;
  capture.enableReopen({parseSourceSpec("/dev/video7"), parseSourceSpec("/dev/video8")},
                       [&](const SourceSpec&) -> std::unique_ptr<FrameSource> {
                         ++opens;
                         throw InputError("cannot be opened");
                       });
  for (double now = 0.0; now < 3.0; now += 0.1) {
    capture.reopenDue(now);
    capture.grabAll();
    capture.retrieveAll();
  }
  EXPECT_EQ(capture.state(1), CameraState::kFinished);
  // Only cam0 is retried: first attempt 0.5 s after the stop, then 1 s, 2 s later (< 3 s).
  EXPECT_EQ(opens, 2);
  EXPECT_EQ(capture.state(0), CameraState::kStopped);
}
