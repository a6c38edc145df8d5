#include <gtest/gtest.h>

#include "test_support/temp_files.h"

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
