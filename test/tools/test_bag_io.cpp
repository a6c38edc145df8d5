// Bag input and output: a small 3-camera bag is written in the test, read back, and every bad
// input gets its one-line message.
#include <gtest/gtest.h>

#include <rosbag/bag.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/String.h>
#include <tf2_msgs/TFMessage.h>
#include "test_support/temp_files.h"

#include <sys/stat.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <random>
#include <regex>
#include <tuple>
#include <utility>

#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/ros/bag_input.h"
#include "sag_hand_tracker/ros/bag_output.h"
#include "sag_hand_tracker/ros/checked_subscription.h"
#include "sag_hand_tracker/ros/conversions.h"
#include "sag_hand_tracker/ros/message_bounds.h"
#include "sag_hand_tracker/ros/sog_conversions.h"
#include "sag_hand_tracker/util/input_limits.h"
#include "sag_hand_tracker/util/types.h"

using namespace sag_hand_tracker;
namespace fs = std::filesystem;

namespace {

constexpr int kWidth = 32;
constexpr int kHeight = 24;

Camera makeCamera(int id) {
  Camera camera;
  camera.name = "cam" + std::to_string(id);
  camera.width = kWidth;
  camera.height = kHeight;
  camera.K << 40.0 + id, 0.0, 16.0, 0.0, 41.0 + id, 12.0, 0.0, 0.0, 1.0;
  camera.distortion = {0.01 * id, 0.0, 0.0, 0.0, 0.0};
  // Cameras on a circle around the origin, looking at it (optical z towards the origin).
  const double angle = 2.0 * M_PI * id / 3.0;
  const Eigen::Vector3d centre(0.8 * std::cos(angle), 0.8 * std::sin(angle), 0.5);
  const Eigen::Vector3d z = (-centre).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d root_to_optical = Eigen::Isometry3d::Identity();
  root_to_optical.linear() << x, y, z;
  root_to_optical.translation() = centre;
  camera.world_to_camera = root_to_optical.inverse();
  return camera;
}

cv::Mat makeImage(int camera, int frame) {
  cv::Mat rgb(kHeight, kWidth, CV_8UC3);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      rgb.at<cv::Vec3b>(y, x) =
          cv::Vec3b(static_cast<uchar>(10 * camera + x), static_cast<uchar>(5 * frame + y),
                    static_cast<uchar>(200 - x - camera));
    }
  }
  return rgb;
}

ros::Time frameTime(int frame) { return ros::Time(100, 0) + ros::Duration(0.04 * frame); }

bool sameImage(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

std::string fileBytes(const std::string& file_path) {
  std::ifstream file(file_path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
}

// A bag's top-level records as the walk in bag_input.cpp sees them (a chunk's own records are
// inside its data): file positions of the record, of its data, and for chunks of their header's
// size field.
struct BagRecord {
  int op = -1;
  std::uint64_t record_at = 0;
  std::uint64_t size_field_at = 0;
  std::uint64_t data_at = 0;
  std::uint32_t data_len = 0;
  std::string compression;
};

std::vector<BagRecord> bagRecords(const std::string& bag) {
  const std::string bytes = fileBytes(bag);
  const auto u32 = [&](std::uint64_t at) {
    std::uint32_t value = 0;
    std::memcpy(&value, &bytes[at], 4);
    return value;
  };
  std::vector<BagRecord> records;
  for (std::uint64_t pos = 13; pos + 8 <= bytes.size();) {  // after "#ROSBAG V2.0\n"
    const std::uint32_t header_len = u32(pos);
    BagRecord record;
    for (std::uint64_t at = pos + 4; at < pos + 4 + header_len;) {
      const std::uint32_t field_len = u32(at);
      const std::string field = bytes.substr(at + 4, field_len);
      const std::size_t equals = field.find('=');
      const std::string name = field.substr(0, equals);
      if (name == "op") record.op = static_cast<unsigned char>(field[equals + 1]);
      if (name == "compression") record.compression = field.substr(equals + 1);
      if (name == "size") record.size_field_at = at + 4 + equals + 1;
      at += 4 + field_len;
    }
    record.record_at = pos;
    record.data_at = pos + 4 + header_len + 4;
    record.data_len = u32(pos + 4 + header_len);
    records.push_back(record);
    pos = record.data_at + record.data_len;
  }
  return records;
}

std::vector<BagRecord> chunkRecords(const std::string& bag) {
  std::vector<BagRecord> chunks;
  for (const BagRecord& record : bagRecords(bag)) {
    if (record.op == 0x05) chunks.push_back(record);
  }
  return chunks;
}

// A saved fuzz finding (test/fuzz/corpus/bag/).
std::string corpusBag(const std::string& name) {
  return std::string(SAG_SOURCE_DIR) + "/test/fuzz/corpus/bag/" + name;
}

void overwrite(const std::string& file_path, std::uint64_t at, const void* bytes, std::size_t n) {
  std::fstream file(file_path, std::ios::binary | std::ios::in | std::ios::out);
  file.seekp(static_cast<std::streamoff>(at));
  file.write(static_cast<const char*>(bytes), static_cast<std::streamsize>(n));
}

// Every set of the bag, with its images.
std::vector<FrameSet> readAllSets(const std::string& bag) {
  BagReader reader(bag);
  std::vector<FrameSet> sets;
  FrameSet set;
  while (reader.next(&set)) sets.push_back(set);
  return sets;
}

void expectSameSets(const std::vector<FrameSet>& expected, const std::vector<FrameSet>& actual,
                    const std::string& what) {
  ASSERT_EQ(actual.size(), expected.size()) << what;
  for (std::size_t k = 0; k < expected.size(); ++k) {
    EXPECT_EQ(actual[k].stamp_ns, expected[k].stamp_ns) << what << " set " << k;
    ASSERT_EQ(actual[k].images.size(), expected[k].images.size()) << what << " set " << k;
    for (std::size_t i = 0; i < expected[k].images.size(); ++i) {
      EXPECT_EQ(actual[k].images[i].camera, expected[k].images[i].camera);
      EXPECT_TRUE(sameImage(actual[k].images[i].rgb, expected[k].images[i].rgb))
          << what << " set " << k << " image " << i;
    }
  }
}

class BagFiles : public sag_test::TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    for (int id = 0; id < 3; ++id) cameras_.push_back(makeCamera(id));
  }

  // Opens the bag and reads it to the end; returns the error message.
  static std::string readError(const std::string& bag, const BagReaderOptions& options = {}) {
    return sag_test::inputErrorOf([&] {
      BagReader reader(bag, options);
      FrameSet set;
      while (reader.next(&set)) {
      }
    });
  }

  // The standard test bag: 4 frames of 3 cameras; cam1 misses frame 2; cam2 is bgr8.
  std::string writeGoodBag(const std::string& name,
                           BagCompression compression = BagCompression::kNone) const {
    BagWriter writer(path(name), compression);
    writer.writeStaticTransforms("world", cameras_, frameTime(0));
    for (int frame = 0; frame < 4; ++frame) {
      for (int id = 0; id < 3; ++id) {
        if (frame == 2 && id == 1) continue;
        writer.writeCameraImage(cameras_[id], makeImage(id, frame), frameTime(frame),
                                id == 2 ? "bgr8" : "rgb8");
      }
    }
    writer.close();
    return path(name);
  }

  // A bag of 2 frames of the 3 cameras where `edit` may change each image message and camera_info
  // before it is written, or return false to leave it out.
  template <typename Edit>
  std::string writeEditedBag(const std::string& name, Edit edit, bool with_tf = true,
                             BagCompression compression = BagCompression::kNone) const {
    BagWriter writer(path(name), compression);
    if (with_tf) writer.writeStaticTransforms("world", cameras_, frameTime(0));
    for (int frame = 0; frame < 2; ++frame) {
      for (int id = 0; id < 3; ++id) {
        std_msgs::Header header;
        header.stamp = frameTime(frame);
        header.frame_id = opticalFrame(cameras_[id].name);
        sensor_msgs::Image image = toImageMsg(makeImage(id, frame), header);
        sensor_msgs::CameraInfo info = toCameraInfo(cameras_[id]);
        info.header = header;
        bool write_image = true, write_info = true;
        edit(frame, id, &image, &info, &write_image, &write_info);
        if (write_image) writer.write(imageTopicOf(cameras_[id]), header.stamp, image);
        if (write_info) writer.write(cameraInfoTopicOf(cameras_[id]), header.stamp, info);
      }
    }
    return path(name);
  }

  std::vector<Camera> cameras_;
};

}  // namespace

TEST_F(BagFiles, BagRoundTrip) {
  const std::string bag = writeGoodBag("good.bag");
  BagReader reader(bag);
  EXPECT_EQ(reader.rootFrame(), "world");
  EXPECT_EQ(reader.cameraIds(), (std::vector<int>{0, 1, 2}));
  ASSERT_EQ(reader.cameras().size(), 3u);
  for (int id = 0; id < 3; ++id) {
    const Camera& camera = reader.cameras()[id];
    EXPECT_EQ(camera.name, cameras_[id].name);
    EXPECT_EQ(camera.width, kWidth);
    EXPECT_EQ(camera.height, kHeight);
    EXPECT_TRUE(camera.K.isApprox(cameras_[id].K, 1e-12));
    EXPECT_EQ(camera.distortion, cameras_[id].distortion);
    EXPECT_TRUE(
        camera.world_to_camera.matrix().isApprox(cameras_[id].world_to_camera.matrix(), 1e-9))
        << camera.name;
  }
  EXPECT_EQ(reader.statistics().image_messages, 11u);

  BagReader moved(std::move(reader));  // readers can be kept in containers
  FrameSet set;
  for (int frame = 0; frame < 4; ++frame) {
    ASSERT_TRUE(moved.next(&set)) << frame;
    EXPECT_EQ(set.stamp_ns, static_cast<std::int64_t>(frameTime(frame).toNSec()));
    EXPECT_NEAR(set.stamp(), frameTime(frame).toSec(), 1e-9);
    std::vector<int> expected_cameras =
        frame == 2 ? std::vector<int>{0, 2} : std::vector<int>{0, 1, 2};
    ASSERT_EQ(set.images.size(), expected_cameras.size());
    for (std::size_t k = 0; k < set.images.size(); ++k) {
      EXPECT_EQ(set.images[k].camera, expected_cameras[k]);
      // bgr8 (cam2) comes back in RGB order, like rgb8.
      EXPECT_TRUE(sameImage(set.images[k].rgb, makeImage(expected_cameras[k], frame)))
          << "frame " << frame << " camera " << expected_cameras[k];
    }
  }
  EXPECT_FALSE(moved.next(&set));
  EXPECT_FALSE(moved.next(&set));
  const BagReaderStatistics& stats = moved.statistics();
  EXPECT_EQ(stats.sets, 4u);
  EXPECT_EQ(stats.incomplete_sets, 1u);
  EXPECT_EQ(stats.images_read, 11u);
  EXPECT_EQ(stats.dropped_images, 0u);
  EXPECT_GT(stats.decode_seconds, 0.0);
  EXPECT_DOUBLE_EQ(moved.progress(), 1.0);
}

TEST_F(BagFiles, BagGroupsInterleavedImagesByHeaderStamp) {
  // Recorded out of step: cam2's image of frame k arrives after cam0's image of frame k + 1, and
  // a duplicate and a hopelessly late image are dropped.
  BagWriter writer(path("interleaved.bag"));
  writer.writeStaticTransforms("world", cameras_, frameTime(0));
  ros::Time record = frameTime(0);
  auto put = [&](int id, int frame) {
    std_msgs::Header header;
    header.stamp = frameTime(frame);
    header.frame_id = opticalFrame(cameras_[id].name);
    sensor_msgs::CameraInfo info = toCameraInfo(cameras_[id]);
    info.header = header;
    record += ros::Duration(0.001);
    writer.write(imageTopicOf(cameras_[id]), record, toImageMsg(makeImage(id, frame), header));
    writer.write(cameraInfoTopicOf(cameras_[id]), record, info);
  };
  put(0, 0);
  put(1, 0);
  put(0, 1);
  put(2, 0);
  put(1, 1);
  put(1, 1);  // duplicate
  put(0, 2);
  put(2, 1);
  put(1, 2);
  put(2, 2);
  put(2, 0);  // late: frame 0 is long gone
  writer.close();

  BagReader reader(path("interleaved.bag"));
  FrameSet set;
  for (int frame = 0; frame < 3; ++frame) {
    ASSERT_TRUE(reader.next(&set));
    EXPECT_EQ(set.stamp_ns, static_cast<std::int64_t>(frameTime(frame).toNSec()));
    ASSERT_EQ(set.images.size(), 3u) << frame;
    for (int id = 0; id < 3; ++id) {
      EXPECT_EQ(set.images[id].camera, id);
      EXPECT_TRUE(sameImage(set.images[id].rgb, makeImage(id, frame)));
    }
  }
  EXPECT_FALSE(reader.next(&set));
  EXPECT_EQ(reader.statistics().dropped_images, 2u);
  EXPECT_EQ(reader.statistics().incomplete_sets, 0u);
}

TEST_F(BagFiles, BagStreamsWithBoundedPendingSets) {
  // cam1 stops after frame 0: each later set waits for at most max_pending_sets newer sets, then
  // goes out with the cameras present, in stamp order, long before the end of the bag.
  constexpr int kFrames = 12;
  {
    BagWriter writer(path("dead.bag"));
    writer.writeStaticTransforms("world", cameras_, frameTime(0));
    for (int frame = 0; frame < kFrames; ++frame) {
      for (int id = 0; id < 3; ++id) {
        if (id == 1 && frame > 0) continue;
        writer.writeCameraImage(cameras_[id], makeImage(id, frame), frameTime(frame));
      }
    }
  }
  BagReaderOptions options;
  options.max_pending_sets = 2;
  BagReader reader(path("dead.bag"), options);
  FrameSet set;
  for (int frame = 0; frame < kFrames; ++frame) {
    ASSERT_TRUE(reader.next(&set));
    EXPECT_EQ(set.stamp_ns, static_cast<std::int64_t>(frameTime(frame).toNSec()));
    EXPECT_EQ(set.images.size(), frame == 0 ? 3u : 2u);
    // Streamed: set k is out once at most max_pending_sets + 1 newer sets have been read.
    const std::uint64_t images_up_to_frame = 3 + 2 * (frame + options.max_pending_sets + 1);
    EXPECT_LE(reader.statistics().images_read, images_up_to_frame) << frame;
  }
  EXPECT_FALSE(reader.next(&set));
  EXPECT_EQ(reader.statistics().incomplete_sets, static_cast<std::uint64_t>(kFrames - 1));
}

TEST_F(BagFiles, BagCameraSubset) {
  const std::string bag = writeGoodBag("good.bag");
  BagReaderOptions options;
  options.cameras = {2, 0};
  BagReader reader(bag, options);
  EXPECT_EQ(reader.cameraIds(), (std::vector<int>{0, 2}));
  ASSERT_EQ(reader.cameras().size(), 2u);
  EXPECT_EQ(reader.cameras()[1].name, "cam2");
  EXPECT_EQ(reader.statistics().image_messages, 8u);
  FrameSet set;
  int sets = 0;
  while (reader.next(&set)) {
    ASSERT_EQ(set.images.size(), 2u);  // cam1's gap does not matter here
    EXPECT_EQ(set.images[1].camera, 1);
    EXPECT_TRUE(sameImage(set.images[1].rgb, makeImage(2, sets)));
    ++sets;
  }
  EXPECT_EQ(sets, 4);
  EXPECT_EQ(reader.statistics().incomplete_sets, 0u);

  options.cameras = {0, 5};
  EXPECT_NE(readError(bag, options)
                .find("camera 5 (/cam5/image_raw) is not in the bag (cameras: "
                      "0 1 2)"),
            std::string::npos);
}

TEST_F(BagFiles, BagComposesTfChains) {
  // world -> rig -> mount<i> -> cam<i>_optical_frame, in two tf messages.
  const std::string bag = writeEditedBag(
      "chain.bag", [](int, int, sensor_msgs::Image*, sensor_msgs::CameraInfo*, bool*, bool*) {},
      false);
  Eigen::Isometry3d world_to_rig = Eigen::Isometry3d::Identity();
  world_to_rig.linear() = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  world_to_rig.translation() = Eigen::Vector3d(0.1, 0.2, 0.3);
  {
    rosbag::Bag raw;
    raw.open(bag, rosbag::bagmode::Append);
    tf2_msgs::TFMessage first, second;
    auto link = [](const std::string& parent, const std::string& child,
                   const Eigen::Isometry3d& pose) {
      geometry_msgs::TransformStamped transform;
      transform.header.frame_id = parent;
      transform.child_frame_id = child;
      transform.transform = toTransformMsg(pose);
      return transform;
    };
    first.transforms.push_back(link("world", "rig", world_to_rig));
    for (int id = 0; id < 3; ++id) {
      // Pose of the camera in the rig frame, split at an arbitrary mount frame.
      const Eigen::Isometry3d rig_to_optical =
          world_to_rig.inverse() * cameras_[id].world_to_camera.inverse();
      Eigen::Isometry3d rig_to_mount = Eigen::Isometry3d::Identity();
      rig_to_mount.translation() = Eigen::Vector3d(0.05 * id, 0.0, 1.0);
      const std::string mount = "mount" + std::to_string(id);
      first.transforms.push_back(link("/rig", mount, rig_to_mount));
      second.transforms.push_back(
          link(mount, opticalFrame(cameras_[id].name), rig_to_mount.inverse() * rig_to_optical));
    }
    raw.write("/tf_static", frameTime(0), first);
    raw.write("/tf_static", frameTime(0), second);
  }
  BagReader reader(bag);
  EXPECT_EQ(reader.rootFrame(), "world");
  for (int id = 0; id < 3; ++id) {
    EXPECT_TRUE(reader.cameras()[id].world_to_camera.matrix().isApprox(
        cameras_[id].world_to_camera.matrix(), 1e-9));
  }
  BagReaderOptions in_rig;
  in_rig.root_frame = "rig";
  BagReader rig_reader(bag, in_rig);
  EXPECT_EQ(rig_reader.rootFrame(), "rig");
  for (int id = 0; id < 3; ++id) {
    EXPECT_TRUE(rig_reader.cameras()[id].world_to_camera.matrix().isApprox(
        (cameras_[id].world_to_camera * world_to_rig).matrix(), 1e-9));
  }
  BagReaderOptions elsewhere;
  elsewhere.root_frame = "table";
  EXPECT_NE(readError(bag, elsewhere)
                .find("root frame 'table' is not a frame of /tf_static (the cameras' tree's root "
                      "is 'world')"),
            std::string::npos);
  // A frame of the tree that is not above every camera: camera 1's mount holds only camera 1.
  BagReaderOptions beside;
  beside.root_frame = "mount1";
  EXPECT_NE(readError(bag, beside)
                .find("root frame 'mount1' is not above camera cam0 ('cam0_optical_frame') in "
                      "/tf_static: it must be above every camera, e.g. the tree's root 'world'"),
            std::string::npos);
}

TEST_F(BagFiles, BagErrorMissingBag) {
  const std::string message = readError(path("absent.bag"));
  EXPECT_EQ(message, path("absent.bag") + ": bag file does not exist");
}

TEST_F(BagFiles, BagErrorUnreadableBag) {
  std::ofstream(path("text.bag")) << "this is not a bag\n";
  const std::string message = readError(path("text.bag"));
  EXPECT_EQ(message.rfind(path("text.bag") + ": cannot read the bag: ", 0), 0u) << message;
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  // rosbag would read these (any "#ROS<word> V<n>.<m>" line) without checking record lengths.
  for (const std::string first_line : {"#ROSBA+ V2.0\n", "#ROSRECORD V1.2\n", "#ROSBAG V2.1\n"}) {
    std::ofstream(path("lookalike.bag"), std::ios::binary)
        << first_line << std::string("\x45\0\0\0\x04\0\0\0op=\x03", 12) << std::string(64, ' ');
    EXPECT_EQ(readError(path("lookalike.bag")),
              path("lookalike.bag") +
                  ": cannot read the bag: it is not a ROS bag of format 2.0 (the file must begin "
                  "with '#ROSBAG V2.0')")
        << first_line;
  }
}

TEST_F(BagFiles, BagErrorNoFrames) {
  { BagWriter writer(path("empty.bag")); }
  EXPECT_EQ(readError(path("empty.bag")), path("empty.bag") + ": the bag is empty: no frames");
}

TEST_F(BagFiles, BagErrorNoImageTopics) {
  {
    BagWriter writer(path("noimages.bag"));
    writer.writeStaticTransforms("world", cameras_, frameTime(0));
    std_msgs::String text;
    text.data = "hello";
    writer.write("/chatter", frameTime(0), text);
    writer.write("/camera/image", frameTime(0), toImageMsg(makeImage(0, 0), std_msgs::Header()));
  }
  EXPECT_EQ(readError(path("noimages.bag")),
            path("noimages.bag") +
                ": no image topics (/cam<i>/image_raw) in the bag; it has: /camera/image, "
                "/chatter, /tf_static");
}

TEST_F(BagFiles, BagErrorCameraWithoutCameraInfo) {
  const std::string bag =
      writeEditedBag("noinfo.bag", [](int, int id, sensor_msgs::Image*, sensor_msgs::CameraInfo*,
                                      bool*, bool* write_info) { *write_info = id != 1; });
  EXPECT_EQ(readError(bag),
            bag + ": camera cam1 has no camera_info (no messages on /cam1/camera_info)");
  BagReaderOptions without_cam1;
  without_cam1.cameras = {0, 2};
  EXPECT_NO_THROW(BagReader(bag, without_cam1));
}

TEST_F(BagFiles, BagErrorMissingExtrinsics) {
  const std::string no_tf = writeEditedBag(
      "notf.bag", [](int, int, sensor_msgs::Image*, sensor_msgs::CameraInfo*, bool*, bool*) {},
      false);
  EXPECT_EQ(readError(no_tf), no_tf +
                                  ": missing extrinsics for camera cam0: the bag has no "
                                  "/tf_static");

  {
    BagWriter writer(path("partial.bag"));
    writer.writeStaticTransforms("world", {cameras_[0], cameras_[2]}, frameTime(0));
    for (int id = 0; id < 3; ++id) {
      writer.writeCameraImage(cameras_[id], makeImage(id, 0), frameTime(0));
    }
  }
  EXPECT_EQ(readError(path("partial.bag")),
            path("partial.bag") +
                ": missing extrinsics for camera cam1: no transform to 'cam1_optical_frame' in "
                "/tf_static");

  {
    BagWriter writer(path("trees.bag"));
    writer.writeStaticTransforms("world", {cameras_[0], cameras_[1]}, frameTime(0));
    writer.writeStaticTransforms("table", {cameras_[2]}, frameTime(0));
    for (int id = 0; id < 3; ++id) {
      writer.writeCameraImage(cameras_[id], makeImage(id, 0), frameTime(0));
    }
  }
  EXPECT_EQ(readError(path("trees.bag")),
            path("trees.bag") +
                ": the cameras are in different tf trees: cam0 under 'world', cam2 under 'table'");
}

// tf2 keeps the last of two static transforms to one frame without a word; a camera has one pose.
TEST_F(BagFiles, BagErrorCameraWithTwoPosesInTfStatic) {
  Camera moved = cameras_[1];
  moved.world_to_camera.translation().x() += 0.05;
  Camera turned = cameras_[1];
  turned.world_to_camera.linear() =
      Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY()).toRotationMatrix() *
      turned.world_to_camera.linear();
  turned.world_to_camera.translation() = -turned.world_to_camera.linear() * cameras_[1].centre();
  const auto write = [&](const std::string& name, const std::vector<Camera>& later,
                         const std::string& later_root) {
    BagWriter writer(path(name));
    writer.writeStaticTransforms("world", cameras_, frameTime(0));
    writer.writeStaticTransforms(later_root, later, frameTime(1));
    // A frame no camera hangs from may change: it is not read.
    tf2_msgs::TFMessage other;
    other.transforms.resize(1);
    other.transforms[0].header.frame_id = "world";
    other.transforms[0].child_frame_id = "gripper";
    other.transforms[0].transform.rotation.w = 1.0;
    writer.write("/tf_static", frameTime(2), other);
    other.transforms[0].transform.translation.z = 0.3;
    writer.write("/tf_static", frameTime(3), other);
    for (int id = 0; id < 3; ++id) {
      writer.writeCameraImage(cameras_[id], makeImage(id, 0), frameTime(0));
    }
    return path(name);
  };
  EXPECT_EQ(readError(write("moved.bag", {moved}, "world")),
            path("moved.bag") +
                ": camera cam1: messages 1 and 2 of /tf_static give 'cam1_optical_frame' two "
                "poses (50.0 mm and 0.00 deg apart): a camera's extrinsics must not change "
                "within a bag");
  EXPECT_EQ(readError(write("turned.bag", {turned}, "world")),
            path("turned.bag") +
                ": camera cam1: messages 1 and 2 of /tf_static give 'cam1_optical_frame' two "
                "poses (0.0 mm and 0.57 deg apart): a camera's extrinsics must not change "
                "within a bag");
  EXPECT_EQ(readError(write("reparented.bag", {cameras_[1]}, "table")),
            path("reparented.bag") +
                ": camera cam1: messages 1 and 2 of /tf_static give 'cam1_optical_frame' two "
                "poses (under 'world' and under 'table'): a camera's extrinsics must not change "
                "within a bag");
  // The same poses recorded twice (a latched publisher seen by two recordings) are one pose.
  const std::string repeated = write("repeated.bag", cameras_, "world");
  BagReader reader(repeated, BagReaderOptions());
  ASSERT_EQ(reader.cameras().size(), 3u);
  EXPECT_TRUE(reader.cameras()[1].world_to_camera.isApprox(cameras_[1].world_to_camera, 1e-9));
}

TEST_F(BagFiles, BagErrorMonoImages) {
  const std::string bag = writeEditedBag("mono.bag", [](int, int id, sensor_msgs::Image* image,
                                                        sensor_msgs::CameraInfo*, bool*, bool*) {
    if (id != 2) return;
    image->encoding = "mono8";
    image->step = image->width;
    image->data.resize(image->step * image->height);
  });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam2/image_raw at 100.000000: mono image (encoding 'mono8'): "
                                "the tracker needs colour images, rgb8 or bgr8");
}

TEST_F(BagFiles, BagErrorUnsupportedEncoding) {
  const std::string bag = writeEditedBag("yuv.bag", [](int frame, int id, sensor_msgs::Image* image,
                                                       sensor_msgs::CameraInfo*, bool*, bool*) {
    if (id == 0 && frame == 1) image->encoding = "yuv422";
  });
  // The first images are fine: the error comes while reading, at the bad image.
  BagReader reader(bag);
  FrameSet set;
  EXPECT_TRUE(reader.next(&set));
  EXPECT_EQ(sag_test::inputErrorOf([&] { reader.next(&set); }),
            bag +
                ": /cam0/image_raw at 100.040000: unsupported image encoding 'yuv422' "
                "(expected rgb8 or bgr8)");
}

// An image whose data is not exactly step x height bytes: fewer were refused, more were silently
// accepted (the extra bytes ignored: a wrong height or step). Both are refused alike now, with the
// topic and the stamp; a step padded beyond width x 3 is fine.
TEST_F(BagFiles, BagErrorImageDataNotStepTimesHeight) {
  const auto edited = [this](const std::string& name,
                             const std::function<void(sensor_msgs::Image*)>& change) {
    return writeEditedBag(name, [&](int frame, int id, sensor_msgs::Image* image,
                                    sensor_msgs::CameraInfo*, bool*, bool*) {
      if (frame == 1 && id == 2) change(image);
    });
  };
  std::string bag =
      edited("longer.bag", [](sensor_msgs::Image* image) { image->data.resize(2304 + 100, 7); });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam2/image_raw at 100.040000: malformed image: 2404 bytes for "
                                "32x24 with step 96, not step x height = 2304");
  bag = edited("shorter.bag", [](sensor_msgs::Image* image) { image->data.resize(2000); });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam2/image_raw at 100.040000: malformed image: 2000 bytes for "
                                "32x24 with step 96, not step x height = 2304");
  bag = edited("step.bag", [](sensor_msgs::Image* image) {
    image->step = 90;
    image->data.resize(90 * 24);
  });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam2/image_raw at 100.040000: malformed image: 2160 bytes for "
                                "32x24 with step 90, less than width x 3 = 96");
  // Rows padded to 100 bytes: the same pixels as the compact image.
  bag = edited("padded.bag", [](sensor_msgs::Image* image) {
    std::vector<std::uint8_t> padded(100 * 24, 0);
    for (int row = 0; row < 24; ++row) {
      std::copy_n(&image->data[row * 96], 96, &padded[row * 100]);
    }
    image->step = 100;
    image->data = padded;
  });
  const std::vector<FrameSet> sets = readAllSets(bag);
  ASSERT_EQ(sets.size(), 2u);
  ASSERT_EQ(sets[1].images.size(), 3u);
  EXPECT_TRUE(sameImage(sets[1].images[2].rgb, makeImage(2, 1)));

  sensor_msgs::Image image = toImageMsg(makeImage(0, 0), std_msgs::Header());
  EXPECT_EQ(imageLayoutProblem(image), "");
  image.data.push_back(0);
  EXPECT_EQ(imageLayoutProblem(image),
            "malformed image: 2305 bytes for 32x24 with step 96, not step x height = 2304");
}

TEST_F(BagFiles, BagErrorImageSizeDisagreesWithCameraInfo) {
  const std::string bag = writeEditedBag(
      "size.bag",
      [](int, int id, sensor_msgs::Image*, sensor_msgs::CameraInfo* info, bool*, bool*) {
        if (id != 1) return;
        info->width = 64;
        info->height = 48;
      });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam1/image_raw at 100.000000: image is 32x24 but its "
                                "camera_info says 64x48");
}

TEST_F(BagFiles, BagErrorBadCameraInfo) {
  const std::string bag = writeEditedBag(
      "uncalibrated.bag",
      [](int, int id, sensor_msgs::Image*, sensor_msgs::CameraInfo* info, bool*, bool*) {
        if (id == 1) info->K = {0, 0, 0, 0, 0, 0, 0, 0, 0};
      });
  const std::string message = readError(bag);
  EXPECT_EQ(
      message.rfind(bag + ": camera 'cam1': camera_info has a zero or negative focal length", 0),
      0u)
      << message;
  EXPECT_NE(message.find("(/cam1/camera_info at 100.000000)"), std::string::npos) << message;
}

TEST_F(BagFiles, BagErrorWrongMessageType) {
  {
    BagWriter writer(path("type.bag"));
    writer.writeStaticTransforms("world", cameras_, frameTime(0));
    std_msgs::String text;
    writer.write("/cam0/image_raw", frameTime(0), text);
  }
  EXPECT_EQ(readError(path("type.bag")), path("type.bag") +
                                             ": /cam0/image_raw has type std_msgs/String, expected "
                                             "sensor_msgs/Image");
}

TEST_F(BagFiles, BagErrorCameraInfoChangesSizeMidBag) {
  const std::string bag = writeEditedBag(
      "resized.bag",
      [](int frame, int id, sensor_msgs::Image*, sensor_msgs::CameraInfo* info, bool*, bool*) {
        if (frame == 1 && id == 2) {
          info->width = 64;
          info->height = 48;
        }
      });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam2/camera_info at 100.040000: the image size changes mid-bag "
                                "from 32x24 to 64x48 (one calibration per camera is supported)");
}

// A later camera_info with another K, D or distortion model (or a non-finite one) was ignored: the
// first one is the camera, so a change is refused with the topic and the stamp.
TEST_F(BagFiles, BagErrorCameraInfoChangesCalibrationMidBag) {
  const auto later = [this](const std::string& name,
                            const std::function<void(sensor_msgs::CameraInfo*)>& change) {
    return writeEditedBag(name, [&](int frame, int id, sensor_msgs::Image*,
                                    sensor_msgs::CameraInfo* info, bool*, bool*) {
      if (frame == 1 && id == 1) change(info);
    });
  };
  std::string bag = later("k.bag", [](sensor_msgs::CameraInfo* info) { info->K[2] += 1.0; });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam1/camera_info: the calibration of camera cam1 changes "
                                "(camera matrix K) at t=100.040000; one calibration per camera is "
                                "supported");
  bag = later("nan.bag", [](sensor_msgs::CameraInfo* info) {
    info->K[0] = std::numeric_limits<double>::quiet_NaN();
  });
  EXPECT_EQ(readError(bag),
            bag +
                ": /cam1/camera_info: the calibration of camera cam1 is not finite "
                "(K or D) at t=100.040000; one calibration per camera is supported");
  bag = later("d.bag", [](sensor_msgs::CameraInfo* info) { info->D[0] = 1e6; });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam1/camera_info: the calibration of camera cam1 changes "
                                "(distortion) at t=100.040000; one calibration per camera is "
                                "supported");
  bag = later("frame.bag",
              [](sensor_msgs::CameraInfo* info) { info->header.frame_id = "cam2_optical_frame"; });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam1/camera_info: the calibration of camera cam1 changes "
                                "(frame_id 'cam1_optical_frame' to 'cam2_optical_frame') at "
                                "t=100.040000; one calibration per camera is supported");
  // The same calibration again, as drivers publish it with every image, is fine.
  EXPECT_EQ(readAllSets(writeGoodBag("good.bag")).size(), 4u);
}

// A principal point far off the image or a huge skew in camera_info is refused (they were not).
TEST_F(BagFiles, BagErrorPrincipalPointAndSkewInCameraInfo) {
  const auto edited = [this](const std::string& name, int index, double value) {
    return writeEditedBag(
        name, [&](int, int id, sensor_msgs::Image*, sensor_msgs::CameraInfo* info, bool*, bool*) {
          if (id == 1) info->K[index] = value;
        });
  };
  std::string bag = edited("cx.bag", 2, -5000.0);
  std::string message = readError(bag);
  EXPECT_EQ(message.rfind(bag + ": camera 'cam1': principal point (cx -5000, cy 12) outside", 0),
            0u)
      << message;
  EXPECT_NE(message.find("(/cam1/camera_info at 100.000000)"), std::string::npos) << message;
  bag = edited("cy.bag", 5, 1e300);
  message = readError(bag);
  EXPECT_NE(message.find("principal point (cx 16, cy 1e+300)"), std::string::npos) << message;
  bag = edited("skew.bag", 1, 1e6);
  message = readError(bag);
  EXPECT_NE(message.find("camera 'cam1': skew K(0,1) = 1e+06 exceeds the focal length fx = 41"),
            std::string::npos)
      << message;
}

// NaN or infinity in camera_info's projection matrix P, and a rectification matrix R that is not a
// rotation (scaled, a reflection) were accepted (the tracker uses K and D only): refused with the
// topic and the stamp, in the first camera_info as in a later one. An all-zero R is a driver that
// leaves R unset, and is accepted.
TEST_F(BagFiles, BagErrorRectificationAndProjectionMatricesInCameraInfo) {
  const auto edited = [this](const std::string& name, int at_frame,
                             const std::function<void(sensor_msgs::CameraInfo*)>& change) {
    return writeEditedBag(name, [&](int frame, int id, sensor_msgs::Image*,
                                    sensor_msgs::CameraInfo* info, bool*, bool*) {
      if (frame == at_frame && id == 1) change(info);
    });
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  std::string bag =
      edited("p_nan.bag", 0, [&](sensor_msgs::CameraInfo* info) { info->P[5] = nan; });
  EXPECT_EQ(readError(bag), bag +
                                ": camera 'cam1': camera_info has a non-finite projection matrix P "
                                "(/cam1/camera_info at 100.000000)");
  bag = edited("r_inf.bag", 0, [&](sensor_msgs::CameraInfo* info) { info->R[0] = -inf; });
  EXPECT_EQ(readError(bag),
            bag +
                ": camera 'cam1': camera_info has a non-finite rectification matrix "
                "R (/cam1/camera_info at 100.000000)");
  // A driver that never sets R: every camera_info of cam1 with R all zeros.
  bag = writeEditedBag("r_zero.bag", [](int, int id, sensor_msgs::Image*,
                                        sensor_msgs::CameraInfo* info, bool*, bool*) {
    if (id == 1) info->R.fill(0.0);
  });
  EXPECT_NO_THROW({
    BagReader reader(bag, BagReaderOptions{});
    FrameSet set;
    int sets = 0;
    while (reader.next(&set)) ++sets;
    EXPECT_GT(sets, 0);
  });
  bag = edited("r_scaled.bag", 0, [](sensor_msgs::CameraInfo* info) {
    for (double& value : info->R) value *= 2.0;
  });
  EXPECT_EQ(readError(bag),
            bag +
                ": camera 'cam1': camera_info has a rectification matrix R that is "
                "not a rotation (R R^T differs from the identity by up to 3, det 8) "
                "(/cam1/camera_info at 100.000000)");
  bag = edited("r_mirror.bag", 0, [](sensor_msgs::CameraInfo* info) { info->R[8] = -1.0; });
  EXPECT_NE(readError(bag).find("not a rotation (R R^T differs from the identity by up to 0, det "
                                "-1)"),
            std::string::npos);
  // A later camera_info: non-finite, or another R or P than the first one's.
  bag = edited("later_p.bag", 1, [&](sensor_msgs::CameraInfo* info) { info->P[0] = inf; });
  EXPECT_EQ(readError(bag),
            bag +
                ": /cam1/camera_info: the calibration of camera cam1 is not finite "
                "(R or P) at t=100.040000; one calibration per camera is supported");
  bag = edited("later_r.bag", 1, [](sensor_msgs::CameraInfo* info) { info->R.fill(0.0); });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam1/camera_info: the calibration of camera cam1 changes "
                                "(rectification matrix R) at t=100.040000; one calibration per "
                                "camera is supported");
  bag = edited("later_p2.bag", 1, [](sensor_msgs::CameraInfo* info) { info->P[0] += 1.0; });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam1/camera_info: the calibration of camera cam1 changes "
                                "(projection matrix P) at t=100.040000; one calibration per camera "
                                "is supported");
  // A rotation printed with 6 digits (a calibration file's) is a rotation.
  const double c = 0.999848, s = 0.017452;  // 1 degree about x
  bag = writeEditedBag("r_rounded.bag", [&](int, int id, sensor_msgs::Image*,
                                            sensor_msgs::CameraInfo* info, bool*, bool*) {
    if (id == 1) info->R = {1, 0, 0, 0, c, -s, 0, s, c};
  });
  EXPECT_EQ(readAllSets(bag).size(), 2u);
}

// A rational_polynomial camera_info with plumb_bob's 5 coefficients was padded with zeros, i.e.
// taken as plumb_bob: refused with the model and the count it has.
TEST_F(BagFiles, BagErrorRationalPolynomialWithFiveCoefficients) {
  const std::string bag = writeEditedBag(
      "rational5.bag",
      [](int, int id, sensor_msgs::Image*, sensor_msgs::CameraInfo* info, bool*, bool*) {
        if (id == 1) info->distortion_model = "rational_polynomial";  // D: plumb_bob's 5
      });
  EXPECT_EQ(readError(bag), bag +
                                ": camera 'cam1': camera_info has 5 distortion coefficients for "
                                "rational_polynomial (expected 8: k1 k2 p1 p2 k3 k4 k5 k6; 5 are "
                                "plumb_bob's) (/cam1/camera_info at 100.000000)");
}

// camera_info's frame_id picks the camera's frame in /tf_static. Two cameras naming one frame got
// one pose, and images of another frame than their camera_info's were tracked with the
// extrinsics of that one; both are refused with the topics and the frames. (Our render_bag
// writes one frame_id, <camera>_optical_frame, on both topics.)
TEST_F(BagFiles, BagErrorCameraInfoFrameIdsMustNameOneFramePerCamera) {
  const auto withFrames =
      [this](const std::string& name,
             const std::function<void(int frame, int id, std::string* image, std::string* info)>&
                 change) {
        return writeEditedBag(name, [&](int frame, int id, sensor_msgs::Image* image,
                                        sensor_msgs::CameraInfo* info, bool*, bool*) {
          change(frame, id, &image->header.frame_id, &info->header.frame_id);
        });
      };
  std::string bag =
      withFrames("shared.bag", [](int, int id, std::string* image, std::string* info) {
        if (id == 2) *image = *info = "cam0_optical_frame";
      });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam0/camera_info (frame_id 'cam0_optical_frame') and "
                                "/cam2/camera_info (frame_id 'cam0_optical_frame') name the same "
                                "optical frame 'cam0_optical_frame': each camera needs a frame of "
                                "its own in /tf_static");
  // An empty frame_id means <camera>_optical_frame; a leading slash is the same frame.
  bag = withFrames("shared_default.bag", [](int, int id, std::string* image, std::string* info) {
    if (id == 0) *image = *info = "/cam1_optical_frame";
    if (id == 1) *image = *info = "";
  });
  EXPECT_EQ(readError(bag),
            bag +
                ": /cam0/camera_info (frame_id '/cam1_optical_frame') and "
                "/cam1/camera_info (frame_id '', so 'cam1_optical_frame') name the "
                "same optical frame 'cam1_optical_frame': each camera needs a frame "
                "of its own in /tf_static");
  // Images of another frame: refused at the first image, or where one appears mid-bag.
  bag = withFrames("image_frame.bag", [](int, int id, std::string* image, std::string*) {
    if (id == 1) *image = "cam1_rgb_frame";
  });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam1/image_raw at 100.000000: frame_id 'cam1_rgb_frame' "
                                "differs from /cam1/camera_info's frame_id 'cam1_optical_frame' "
                                "(the frame whose /tf_static pose is the camera's)");
  bag = withFrames("later_frame.bag", [](int frame, int id, std::string* image, std::string*) {
    if (frame == 1 && id == 2) *image = "cam0_optical_frame";
  });
  EXPECT_EQ(readError(bag), bag +
                                ": /cam2/image_raw at 100.040000: frame_id 'cam0_optical_frame' "
                                "differs from /cam2/camera_info's frame_id 'cam2_optical_frame' "
                                "(the frame whose /tf_static pose is the camera's)");
  // An empty frame_id on either side names nothing; a leading slash is the same frame.
  bag = withFrames("lenient.bag", [](int, int id, std::string* image, std::string* info) {
    if (id == 0) *image = "";
    if (id == 1) *info = "";
    if (id == 2) *image = "/cam2_optical_frame";
  });
  EXPECT_EQ(readAllSets(bag).size(), 2u);
  // What render_bag writes passes.
  EXPECT_EQ(readAllSets(writeGoodBag("good.bag")).size(), 4u);
}

// std::stoi threw on /cam99999999999/ ("internal error: stoi"); /cam01/ and cam0/ (no slash) were
// looked up as /cam1/ and /cam0/, which the bag does not have.
TEST_F(BagFiles, BagErrorImageTopicsNotNamingACameraAreRefusedByName) {
  const auto bagWithTopic = [this](const std::string& name, const std::string& topic) {
    BagWriter writer(path(name));
    writer.writeStaticTransforms("world", cameras_, frameTime(0));
    writer.writeCameraImage(cameras_[0], makeImage(0, 0), frameTime(0));
    writer.write(topic, frameTime(0), toImageMsg(makeImage(1, 0), std_msgs::Header()));
    return path(name);
  };
  std::string bag = bagWithTopic("overflow.bag", "/cam99999999999/image_raw");
  EXPECT_EQ(readError(bag), bag +
                                ": /cam99999999999/image_raw: camera number 99999999999 is out of "
                                "range (at most 63)");
  bag = bagWithTopic("64.bag", "/cam64/image_raw");
  EXPECT_EQ(readError(bag),
            bag + ": /cam64/image_raw: camera number 64 is out of range (at most 63)");
  bag = bagWithTopic("zero.bag", "/cam01/image_raw");
  EXPECT_EQ(readError(bag),
            bag +
                ": /cam01/image_raw is not a supported camera image topic: expected "
                "/cam1/image_raw (with a leading slash and no leading zeros)");
  bag = bagWithTopic("slash.bag", "cam2/image_raw");
  EXPECT_EQ(readError(bag), bag +
                                ": cam2/image_raw is not a supported camera image topic: expected "
                                "/cam2/image_raw (with a leading slash and no leading zeros)");
}

// Opening a FIFO blocked in open() (ignoring SIGTERM); it is refused before anything opens it.
TEST_F(BagFiles, BagErrorAFifoIsNotARegularFile) {
  const std::string fifo = path("fifo.bag");
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_EQ(readError(fifo), fifo +
                                 ": is not a regular file (a FIFO, device or socket?), not a bag "
                                 "file");
}

// The rig file's limits hold for the extrinsics of a bag's /tf_static too.
TEST_F(BagFiles, BagErrorExtrinsicsOutsideTheRigLimits) {
  const auto bagWithCameras = [this](const std::string& name, const std::vector<Camera>& cameras) {
    const std::vector<Camera> saved = cameras_;
    cameras_ = cameras;
    const std::string bag = writeEditedBag(
        name, [](int, int, sensor_msgs::Image*, sensor_msgs::CameraInfo*, bool*, bool*) {});
    cameras_ = saved;
    return bag;
  };
  std::vector<Camera> same = cameras_;
  same[2].world_to_camera = same[0].world_to_camera;
  std::string bag = bagWithCameras("same.bag", same);
  EXPECT_EQ(readError(bag), bag +
                                ": /tf_static: camera cam2 is at the same point as camera cam0 "
                                "(closer than 0.001 m)");
  std::vector<Camera> far = cameras_;
  Eigen::Isometry3d root_to_optical = far[1].world_to_camera.inverse();
  root_to_optical.translation().x() = 1e300;
  far[1].world_to_camera = root_to_optical.inverse();
  bag = bagWithCameras("far.bag", far);
  const std::string message = readError(bag);
  EXPECT_EQ(message.rfind(bag + ": /tf_static: camera cam1 is at (1e+300, ", 0), 0u) << message;
  EXPECT_NE(message.find("m in 'world'; translations must lie within +-1000 m"), std::string::npos)
      << message;

  {
    BagWriter writer(path("many.bag"));
    for (int id = 0; id <= kMaxCameras; ++id) {
      writer.write("/cam" + std::to_string(id) + "/image_raw", frameTime(0),
                   toImageMsg(makeImage(0, 0), std_msgs::Header()));
    }
  }
  EXPECT_EQ(
      readError(path("many.bag")),
      path("many.bag") + ": the bag has 65 camera image topics, more than the limit of 64 cameras");
}

TEST_F(BagFiles, BagErrorTruncatedBagSaysSo) {
  const std::string bag = writeGoodBag("cut.bag");
  fs::resize_file(bag, fs::file_size(bag) / 2);
  const std::string message = readError(bag);
  EXPECT_EQ(message.rfind(bag + ": the bag is truncated: it has ", 0), 0u) << message;
}

TEST_F(BagFiles, BagErrorCorruptRecordLengthIsCaughtBeforeRosbagAllocatesIt) {
  // Found by fuzz_bag: rosbag allocated the 2 GB a corrupt header length asked for.
  const std::string bag = writeGoodBag("corrupt.bag");
  {
    std::fstream file(bag, std::ios::binary | std::ios::in | std::ios::out);
    file.seekp(4117);  // the first record: after the magic line (13) and the bag header (4104)
    const std::uint32_t huge = 0x7ffffff0u;
    file.write(reinterpret_cast<const char*>(&huge), 4);
  }
  EXPECT_EQ(readError(bag),
            bag + ": the bag is corrupt: a record header longer than the file at byte 4117");
}

// rosbag parses the records of a compressed chunk after decompressing it, where a check of the
// file cannot see them: the reader decompresses lz4 and bz2 chunks itself and walks their records
// first (a fuzz find). Well-formed compressed bags read exactly as uncompressed ones, also when
// they span many chunks (each chunk's index is checked against that chunk's records).
TEST_F(BagFiles, CompressedBagsReadTheSameFramesAsUncompressed) {
  const std::vector<FrameSet> plain = readAllSets(writeGoodBag("none.bag"));
  ASSERT_EQ(plain.size(), 4u);
  for (const auto& [compression, name] : {std::pair{BagCompression::kLz4, std::string("lz4")},
                                          std::pair{BagCompression::kBz2, std::string("bz2")}}) {
    const std::string bag = writeGoodBag(name + ".bag", compression);
    const std::vector<BagRecord> chunks = chunkRecords(bag);
    ASSERT_FALSE(chunks.empty()) << name;
    for (const BagRecord& chunk : chunks) EXPECT_EQ(chunk.compression, name);
    expectSameSets(plain, readAllSets(bag), name);
    BagReader reader(bag);
    EXPECT_EQ(reader.rootFrame(), "world");
    for (int id = 0; id < 3; ++id) {
      EXPECT_TRUE(reader.cameras()[id].K.isApprox(cameras_[id].K, 1e-12)) << name;
    }
  }

  // 6 frames of 3 cameras of 192 kB each: rosbag's 768 kB chunk threshold makes several chunks.
  std::vector<Camera> large = cameras_;
  for (Camera& camera : large) {
    camera.width = 320;
    camera.height = 200;
  }
  const auto write_large = [&](const std::string& name, BagCompression compression) {
    BagWriter writer(path(name), compression);
    writer.writeStaticTransforms("world", large, frameTime(0));
    for (int frame = 0; frame < 6; ++frame) {
      for (int id = 0; id < 3; ++id) {
        cv::Mat image(200, 320, CV_8UC3);  // the same noise in every bag
        cv::RNG(static_cast<std::uint64_t>(1 + 3 * frame + id))
            .fill(image, cv::RNG::UNIFORM, cv::Scalar::all(0), cv::Scalar::all(256 / (1 + id)));
        writer.writeCameraImage(large[id], image, frameTime(frame));
      }
    }
    writer.close();
    return path(name);
  };
  const std::vector<FrameSet> large_plain =
      readAllSets(write_large("large_none.bag", BagCompression::kNone));
  ASSERT_EQ(large_plain.size(), 6u);
  for (const auto& [compression, name] : {std::pair{BagCompression::kLz4, std::string("lz4")},
                                          std::pair{BagCompression::kBz2, std::string("bz2")}}) {
    const std::string bag = write_large("large_" + name + ".bag", compression);
    EXPECT_GE(chunkRecords(bag).size(), 3u) << name;
    expectSameSets(large_plain, readAllSets(bag), "large " + name);
  }
}

TEST_F(BagFiles, BagErrorCorruptCompressedChunkNamesTheChunkAndTheProblem) {
  for (const auto& [compression, name] : {std::pair{BagCompression::kLz4, std::string("lz4")},
                                          std::pair{BagCompression::kBz2, std::string("bz2")}}) {
    SCOPED_TRACE(name);
    const std::string original = writeGoodBag(name + ".bag", compression);
    const std::vector<BagRecord> chunks = chunkRecords(original);
    ASSERT_EQ(chunks.size(), 1u);
    const BagRecord chunk = chunks[0];
    const std::string where = ": the bag is corrupt: the " + name + " chunk at byte " +
                              std::to_string(chunk.record_at) + " ";
    std::uint32_t size = 0;
    {
      std::ifstream file(original, std::ios::binary);
      file.seekg(static_cast<std::streamoff>(chunk.size_field_at));
      file.read(reinterpret_cast<char*>(&size), 4);
    }
    ASSERT_GT(size, chunk.data_len);  // it is compressed

    const auto edited = [&](const std::string& label, std::uint64_t at, std::uint32_t value) {
      const std::string bag = path(name + "_" + label + ".bag");
      fs::copy_file(original, bag);
      overwrite(bag, at, &value, 4);
      return bag;
    };
    // Bytes in the middle of the compressed data changed.
    const std::string garbled = edited("garbled", chunk.data_at + chunk.data_len / 2, 0x5a5a5a5au);
    const std::string garbled_error = readError(garbled);
    EXPECT_EQ(garbled_error.rfind(
                  garbled + where + "is not valid " +
                      (name == "lz4" ? "lz4 data (roslz4 error " : "bzip2 data (bzip2 error "),
                  0),
              0u)
        << garbled_error;
    // Its declared uncompressed size one byte off either way.
    const std::string larger = edited("larger", chunk.size_field_at, size + 1);
    EXPECT_EQ(readError(larger), larger + where + "decompresses to " + std::to_string(size) +
                                     " bytes, not the " + std::to_string(size + 1) +
                                     " it declares");
    const std::string smaller = edited("smaller", chunk.size_field_at, size - 1);
    EXPECT_EQ(readError(smaller), smaller + where + "decompresses to more than the " +
                                      std::to_string(size - 1) + " bytes it declares");
    // A size above the limit is refused before anything is allocated.
    const std::string huge = edited("huge", chunk.size_field_at, 0xfffffff0u);
    EXPECT_EQ(readError(huge),
              huge + where + "declares 4294967280 uncompressed bytes (the limit is 1 GiB)");
  }
}

// rosbag reads the connection records and chunk infos from the header's index_pos on; pointing
// into a record made it take a header length from that record's bytes and allocate 2.3 GB
// (corpus/bag/crash_rosbag_index_pos_mid_record).
TEST_F(BagFiles, BagErrorIndexPositionInsideARecordIsCaughtBeforeRosbagAllocates) {
  const std::string bag = writeGoodBag("index.bag");
  const std::string bytes = fileBytes(bag);
  const std::size_t field = bytes.find("index_pos=") + std::strlen("index_pos=");
  std::uint64_t index_pos = 0;
  std::memcpy(&index_pos, &bytes[field], 8);
  for (const std::uint64_t moved : {index_pos + 1, index_pos + 5, index_pos - 4}) {
    overwrite(bag, field, &moved, 8);
    EXPECT_EQ(readError(bag), bag + ": the bag is corrupt: its header's index position (byte " +
                                  std::to_string(moved) + ") is not where a record starts");
  }
  overwrite(bag, field, &index_pos, 8);
  EXPECT_EQ(readAllSets(bag).size(), 4u);  // restored, it reads again
}

// Two fuzz finds in what rosbag reads from the index records and chunk infos as it opens a bag.
// It reads as many index entries (12 bytes) and chunk info entries (8 bytes) as the record's count
// field says, whatever the record holds: a count above it made rosbag read on into the next record
// and take a header length from its middle (2.3 GB allocated,
// corpus/bag/crash_rosbag_index_count_beyond_data); the count must match the data. And it makes a
// ros::Time of each index entry's time, which throws std::runtime_error when the nanoseconds carry
// the seconds past 32 bits (corpus/bag/crash_rosbag_index_time_out_of_range).
TEST_F(BagFiles, BagErrorIndexRecordsRosbagWouldMisreadAreCaughtBeforeItReadsThem) {
  const std::string good = writeGoodBag("counts.bag");
  const std::string bytes = fileBytes(good);
  // The count fields (<length 10>count=<uint32>) of the first index record and of the chunk info,
  // the last record; a record's header starts 4 bytes after the record.
  const std::string count_field("\x0a\0\0\0count=", 10);
  const std::size_t index_count = bytes.find(count_field);
  const std::size_t chunk_info_count = bytes.rfind(count_field);
  ASSERT_NE(index_count, std::string::npos);
  ASSERT_NE(index_count, chunk_info_count);
  const std::vector<BagRecord> records = bagRecords(good);
  const auto record_of = [&](std::size_t field) {  // the record whose header holds `field`
    for (const BagRecord& record : records) {
      if (field > record.record_at && field < record.data_at) {
        return std::pair{record.record_at, record.data_len};
      }
    }
    ADD_FAILURE() << "no record holds byte " << field;
    return std::pair{std::uint64_t{0}, std::uint32_t{0}};
  };
  for (const auto& [field, entry_bytes, what] :
       {std::tuple{index_count, 12u, std::string("an index record")},
        std::tuple{chunk_info_count, 8u, std::string("a chunk info")}}) {
    const auto [record_at, data_len] = record_of(field);
    const std::uint32_t entries = data_len / entry_bytes;
    ASSERT_EQ(data_len, entries * entry_bytes) << what;
    for (const std::uint32_t count : {entries + 1, entries - 1, entries + 1000000}) {
      const std::string bag = path("count.bag");
      fs::copy_file(good, bag, fs::copy_options::overwrite_existing);
      overwrite(bag, field + count_field.size(), &count, 4);
      EXPECT_EQ(readError(bag), bag + ": the bag is corrupt: " + what + " of " +
                                    std::to_string(count) + " entries (" +
                                    std::to_string(std::uint64_t{count} * entry_bytes) +
                                    " bytes) in " + std::to_string(data_len) +
                                    " bytes of data at byte " + std::to_string(record_at));
    }
  }
  const std::string found = corpusBag("crash_rosbag_index_count_beyond_data");
  EXPECT_EQ(readError(found),
            found +
                ": the bag is corrupt: an index record of 9 entries (108 bytes) in 24 bytes of "
                "data at byte 7549");

  // The first entry's time: the largest second, and nanoseconds that carry a second.
  const std::uint64_t index_at = record_of(index_count).first;
  std::uint32_t header_len = 0;
  std::memcpy(&header_len, &bytes[index_at], 4);
  const std::uint64_t entry_at = index_at + 4 + header_len + 4;
  const std::string bag = path("time.bag");
  for (const std::uint32_t nsec : {1000000000u, 3105751039u}) {
    fs::copy_file(good, bag, fs::copy_options::overwrite_existing);
    const std::uint32_t entry_time[2] = {0xffffffffu, nsec};
    overwrite(bag, entry_at, entry_time, 8);
    EXPECT_EQ(readError(bag),
              bag + ": the bag is corrupt: the index record at byte " + std::to_string(index_at) +
                  " has a time out of range (4294967295 s " + std::to_string(nsec) + " ns)");
  }
  const std::string time_found = corpusBag("crash_rosbag_index_time_out_of_range");
  EXPECT_EQ(readError(time_found),
            time_found +
                ": the bag is corrupt: the index record at byte 7786 has a time out of range "
                "(4294967295 s 3105751039 ns)");
  EXPECT_EQ(readAllSets(good).size(), 4u);
}

// The fuzzer's finding (session 6): an index entry pointing into a record of an lz4 chunk (2 bytes
// before the next one) made rosbag parse message bytes as a record header, whose field length sent
// ros::Header::parse 262 139 bytes past a 3 316-byte buffer. The chunk is now decompressed and its
// records walked before rosbag opens the bag; the entry is refused with the chunk it points into.
TEST(BagRecords, AnIndexEntryIntoAnLz4BagRecordIsRefusedBeforeRosbagParsesIt) {
  const std::string bag = corpusBag("crash_lz4_chunk_message_header_overflow");
  // Its chunk holds 14 records; the entry points 2 bytes before the one at byte 2355.
  EXPECT_EQ(sag_test::inputErrorOf([&] { BagReader reader(bag); }),
            bag +
                ": the bag is corrupt: the index record at byte 5195 points at byte 2353 of the "
                "lz4 chunk at byte 4117, where none of its records starts");
}

// The bag fuzz target reads every input through one rosbag::Bag (BagReader's constructor with a
// reused bag). A bag refused half way, inside rosbag's open or while frames are read, must leave
// nothing behind in it: each gives the error a fresh reader gives, and the good bag read next
// gives what a fresh reader gives. The bags are lz4 bags whose chunk starts at the same byte, so a
// chunk that rosbag kept decompressed from the file before would be read again.
TEST_F(BagFiles, AReusedRosbagBagReadsAGoodBagAfterMalformedOnesAsAFreshReaderDoes) {
  const std::string good = writeGoodBag("good.bag", BagCompression::kLz4);
  // Refused while frames are read, after rosbag has opened it and decompressed its chunk.
  const std::string yuv = writeEditedBag(
      "yuv.bag",
      [](int frame, int id, sensor_msgs::Image* image, sensor_msgs::CameraInfo*, bool*, bool*) {
        if (id == 0 && frame == 1) image->encoding = "yuv422";
      },
      true, BagCompression::kLz4);
  ASSERT_EQ(chunkRecords(yuv).at(0).record_at, chunkRecords(good).at(0).record_at);
  // Refused by rosbag half way through opening it: the header declares one connection more than
  // the bag has, so rosbag reads the chunk info after the 7 connection records as an 8th.
  const std::string connections = path("connections.bag");
  fs::copy_file(good, connections);
  {
    const std::string bytes = fileBytes(connections);
    const std::size_t field = bytes.find("conn_count=") + std::strlen("conn_count=");
    std::uint32_t count = 0;
    std::memcpy(&count, &bytes[field], 4);
    ASSERT_EQ(count, 7u);
    ++count;
    overwrite(connections, field, &count, 4);
  }
  // Refused before rosbag sees it.
  const std::string cut = path("cut.bag");
  fs::copy_file(good, cut);
  fs::resize_file(cut, fs::file_size(cut) / 2);

  BagReader fresh(good);
  const std::vector<FrameSet> fresh_sets = readAllSets(good);
  ASSERT_EQ(fresh_sets.size(), 4u);
  rosbag::Bag reused;
  const auto expect_as_fresh = [&](const std::string& after) {
    SCOPED_TRACE("the good bag after " + after);
    BagReader reader(good, reused);
    EXPECT_EQ(reader.rootFrame(), fresh.rootFrame());
    EXPECT_EQ(reader.cameraIds(), fresh.cameraIds());
    ASSERT_EQ(reader.cameras().size(), fresh.cameras().size());
    for (std::size_t i = 0; i < fresh.cameras().size(); ++i) {
      const Camera& camera = reader.cameras()[i];
      EXPECT_EQ(camera.name, fresh.cameras()[i].name);
      EXPECT_EQ(camera.width, fresh.cameras()[i].width);
      EXPECT_EQ(camera.height, fresh.cameras()[i].height);
      EXPECT_EQ(camera.K, fresh.cameras()[i].K);
      EXPECT_EQ(camera.distortion, fresh.cameras()[i].distortion);
      EXPECT_EQ(camera.world_to_camera.matrix(), fresh.cameras()[i].world_to_camera.matrix());
    }
    std::vector<FrameSet> sets;
    FrameSet set;
    while (reader.next(&set)) sets.push_back(set);
    expectSameSets(fresh_sets, sets, "reused bag after " + after);
    EXPECT_EQ(reader.statistics().image_messages, 11u);
    EXPECT_EQ(reader.statistics().images_read, 11u);
    EXPECT_EQ(reader.statistics().sets, 4u);
    EXPECT_EQ(reader.statistics().incomplete_sets, 1u);
    EXPECT_EQ(reader.statistics().dropped_images, 0u);
  };
  expect_as_fresh("nothing");
  EXPECT_FALSE(reused.isOpen());
  for (const std::string& bad : {yuv, connections, cut, path("missing.bag")}) {
    const std::string reused_error = sag_test::inputErrorOf([&] {
      BagReader reader(bad, reused);
      FrameSet set;
      while (reader.next(&set)) {
      }
    });
    EXPECT_EQ(reused_error, readError(bad));
    EXPECT_FALSE(reused.isOpen()) << bad;
    expect_as_fresh(bad);
  }
  EXPECT_EQ(readError(yuv), yuv +
                                ": /cam0/image_raw at 100.040000: unsupported image encoding "
                                "'yuv422' (expected rgb8 or bgr8)");
  const std::string connections_error = readError(connections);
  EXPECT_EQ(connections_error.rfind(connections + ": cannot read the bag: ", 0), 0u)
      << connections_error;
}

TEST_F(BagFiles, BagEmptyPlumbBobDistortionIsNoDistortion) {
  // What a driver without a calibration file publishes; image_geometry divided by zero on it.
  const std::string bag =
      writeEditedBag("nodist.bag", [](int, int, sensor_msgs::Image*, sensor_msgs::CameraInfo* info,
                                      bool*, bool*) { info->D.clear(); });
  BagReader reader(bag);
  for (const Camera& camera : reader.cameras()) EXPECT_FALSE(camera.hasDistortion());
}

TEST_F(BagFiles, BagErrorThreeDistortionCoefficientsNameTheCamera) {
  const std::string bag = writeEditedBag(
      "d3.bag", [](int, int id, sensor_msgs::Image*, sensor_msgs::CameraInfo* info, bool*, bool*) {
        if (id == 1) info->D = {0.1, 0.01, 0.0};
      });
  EXPECT_EQ(readError(bag), bag +
                                ": camera 'cam1': camera_info has 3 distortion coefficients for "
                                "plumb_bob (expected 0, 4 or 5) (/cam1/camera_info at 100.000000)");
}

TEST_F(BagFiles, BagErrorHugeCameraInfoSizeIsALimitNotBadAlloc) {
  const std::string bag = writeEditedBag(
      "huge.bag",
      [](int, int id, sensor_msgs::Image*, sensor_msgs::CameraInfo* info, bool*, bool*) {
        if (id == 0) {
          info->width = 4000000000u;
          info->height = 3000000000u;
        }
      });
  const std::string message = readError(bag);
  EXPECT_NE(message.find("camera 'cam0': camera_info: image size 4000000000x3000000000 exceeds "
                         "the limit"),
            std::string::npos)
      << message;
}

TEST_F(BagFiles, BagReportsStampsThatNearlyMatchAndStampsGoingBackwards) {
  BagWriter writer(path("stamps.bag"));
  writer.writeStaticTransforms("world", cameras_, frameTime(0));
  for (int frame = 0; frame < 3; ++frame) {
    for (int id = 0; id < 3; ++id) {
      // cam1 is stamped 5 us after the others.
      const ros::Time stamp = frameTime(frame) + ros::Duration(id == 1 ? 5e-6 : 0.0);
      writer.writeCameraImage(cameras_[id], makeImage(id, frame), stamp);
    }
  }
  // cam0 then goes back in time: recorded last, its header stamp is frame 1's.
  std_msgs::Header header;
  header.stamp = frameTime(1);
  header.frame_id = opticalFrame(cameras_[0].name);
  writer.write(imageTopicOf(cameras_[0]), frameTime(3), toImageMsg(makeImage(0, 9), header));
  writer.close();
  // Identical stamps only: cam1 is never in cam0's set, and that is reported.
  BagReaderOptions identical;
  identical.stamp_tolerance = 0.0;
  BagReader reader(path("stamps.bag"), identical);
  FrameSet set;
  while (reader.next(&set)) {
  }
  const BagReaderStatistics& stats = reader.statistics();
  EXPECT_GE(stats.near_stamp_mismatches, 3u);
  // The image named by its topic, its frame number there and its stamp.
  EXPECT_EQ(stats.first_near_stamp_mismatch,
            "/cam1/image_raw frame 1 at 100.000005 vs cam0 at 100.000000");
  EXPECT_EQ(stats.backward_stamps, 1u);
  EXPECT_EQ(stats.first_backward_stamp, "/cam0/image_raw frame 4 at 100.040000 after 100.080000");

  // The default tolerance (5 ms) makes one set of each frame's three cameras.
  BagReader tolerant(path("stamps.bag"));
  int complete = 0;
  while (tolerant.next(&set)) complete += set.images.size() == 3 ? 1 : 0;
  EXPECT_EQ(complete, 3);
  EXPECT_EQ(tolerant.statistics().near_stamp_mismatches, 0u);
  EXPECT_EQ(tolerant.statistics().tolerated_stamps, 3u);
  EXPECT_NEAR(tolerant.statistics().largest_stamp_difference, 5e-6, 1e-9);
  EXPECT_EQ(tolerant.statistics().backward_stamps, 1u);
}

// A camera exactly half a frame period late is as far from both neighbouring sets: it was missed
// (20 ms at 25 fps, 40 ms at 12.5), and calibrate_hand fitted a hand of thickness x 0.70 from its
// sets of one camera. A camera that drops a frame is not out of step.
TEST_F(BagFiles, BagCountsACameraHalfAFrameLateAsOutOfStep) {
  auto read = [&](const std::string& name, double period, double cam1_late, int dropped_frame) {
    {
      BagWriter writer(path(name));
      writer.writeStaticTransforms("world", cameras_, frameTime(0));
      for (int frame = 0; frame < 10; ++frame) {
        for (int id = 0; id < 3; ++id) {
          if (id == 2 && frame == dropped_frame) continue;
          const ros::Time stamp =
              frameTime(0) + ros::Duration(frame * period + (id == 1 ? cam1_late : 0.0));
          writer.writeCameraImage(cameras_[id], makeImage(id, frame), stamp);
        }
      }
    }
    BagReader reader(path(name));
    FrameSet set;
    long sets = 0;
    while (reader.next(&set)) ++sets;
    return std::make_pair(reader.statistics(), sets);
  };
  for (const auto& [period, late] : {std::pair{0.04, 0.02}, std::pair{0.08, 0.04}}) {
    const auto [stats, sets] = read("late.bag", period, late, -1);
    EXPECT_GE(stats.near_stamp_mismatches, 9u) << period;
    EXPECT_TRUE(camerasOutOfStep(stats, sets)) << period;
    ASSERT_FALSE(stampWarnings(stats, "").empty());
    EXPECT_NE(stampWarnings(stats, "").back().find(
                  "but at most half their camera's frame period (20 ms or more) from another "
                  "camera's set"),
              std::string::npos)
        << stampWarnings(stats, "").back();
  }
  const auto [dropped, dropped_sets] = read("dropped.bag", 0.04, 0.0, 4);
  EXPECT_EQ(dropped.near_stamp_mismatches, 0u);
  EXPECT_EQ(dropped_sets, 10);
  EXPECT_FALSE(camerasOutOfStep(dropped, dropped_sets));
}

// A camera whose stamps leap forward by hours (a clock set forward mid-recording) was tracked on
// without a word; the first leap is named (backward ones already were).
TEST_F(BagFiles, BagNamesStampsThatJumpForwardByMoreThan10Seconds) {
  const std::string bag = path("leap.bag");
  {
    BagWriter writer(bag);
    writer.writeStaticTransforms("world", cameras_, frameTime(0));
    for (int frame = 0; frame < 4; ++frame) {
      for (int id = 0; id < 3; ++id) {
        const ros::Time stamp = frameTime(frame) + ros::Duration(frame >= 2 ? 7200.0 : 0.0);
        writer.writeCameraImage(cameras_[id], makeImage(id, frame), stamp);
      }
    }
  }
  BagReader reader(bag);
  FrameSet set;
  int sets = 0;
  while (reader.next(&set)) ++sets;
  EXPECT_EQ(sets, 4);
  const BagReaderStatistics& stats = reader.statistics();
  EXPECT_EQ(stats.forward_jumps, 3u);  // each camera once
  // The first in the bag's order of the three cameras' images of frame 2.
  EXPECT_TRUE(std::regex_match(
      stats.first_forward_jump,
      std::regex("/cam[0-2]/image_raw frame 3 at 7300\\.080000 after 100\\.040000")))
      << stats.first_forward_jump;
  EXPECT_EQ(stats.backward_stamps, 0u);
  // The good bag (frames 40 ms apart, cam1 missing frame 2) has none.
  BagReader good(writeGoodBag("good.bag"));
  while (good.next(&set)) {
  }
  EXPECT_EQ(good.statistics().forward_jumps, 0u);
}

// An image at a stamp its camera already delivered (recorded twice, or a driver that repeats a
// stamp) is dropped, and the first one is named: before, only a count of dropped images said so.
TEST_F(BagFiles, BagNamesImagesThatRepeatTheirCamerasStamp) {
  const std::string bag = path("repeated.bag");
  {
    BagWriter writer(bag);
    writer.writeStaticTransforms("world", cameras_, frameTime(0));
    for (int frame = 0; frame < 3; ++frame) {
      for (int id = 0; id < 3; ++id) {
        // cam2's frame 2 carries frame 1's stamp: its set is gone by then.
        const ros::Time stamp = frameTime(id == 2 && frame == 2 ? 1 : frame);
        writer.writeCameraImage(cameras_[id], makeImage(id, frame), stamp);
        // cam1's frame 0 is recorded twice: the second joins the same pending set.
        if (id == 1 && frame == 0) writer.writeCameraImage(cameras_[id], makeImage(id, 7), stamp);
      }
    }
  }
  BagReader reader(bag);
  FrameSet set;
  int sets = 0;
  while (reader.next(&set)) {
    ++sets;
    if (set.stamp_ns == static_cast<std::int64_t>(frameTime(0).toNSec())) {
      ASSERT_EQ(set.images.size(), 3u);
      EXPECT_TRUE(sameImage(set.images[1].rgb, makeImage(1, 0))) << "the first image is kept";
    }
  }
  EXPECT_EQ(sets, 3);
  const BagReaderStatistics& stats = reader.statistics();
  EXPECT_EQ(stats.duplicate_stamps, 2u);
  EXPECT_EQ(stats.dropped_images, 2u);
  EXPECT_EQ(stats.first_duplicate_stamp, "/cam1/image_raw frame 2 at 100.000000");
}

// A camera recorded through image_transport's compressed plugin only was left out silently (its
// camera_info read, its images never): it is named, and --cameras may leave it out.
TEST_F(BagFiles, BagErrorACameraWithCompressedImagesOnlyIsNamed) {
  const std::string bag = path("compressed.bag");
  {
    BagWriter writer(bag);
    writer.writeStaticTransforms("world", cameras_, frameTime(0));
    for (int frame = 0; frame < 2; ++frame) {
      for (int id = 0; id < 3; ++id) {
        if (id != 0) {
          writer.writeCameraImage(cameras_[id], makeImage(id, frame), frameTime(frame));
          continue;
        }
        sensor_msgs::CompressedImage compressed;
        compressed.header.stamp = frameTime(frame);
        compressed.header.frame_id = opticalFrame(cameras_[0].name);
        compressed.format = "rgb8; jpeg compressed bgr8";
        compressed.data = {0xff, 0xd8, 0xff, 0xd9};
        writer.write("/cam0/image_raw/compressed", frameTime(frame), compressed);
        sensor_msgs::CameraInfo info = toCameraInfo(cameras_[0]);
        info.header = compressed.header;
        writer.write(cameraInfoTopicOf(cameras_[0]), frameTime(frame), info);
      }
    }
  }
  EXPECT_EQ(readError(bag),
            bag +
                ": /cam0/image_raw/compressed: camera cam0 has compressed images only; the tracker "
                "reads sensor_msgs/Image on /cam0/image_raw (decompress them first, e.g. with "
                "image_transport's republish; track_bag --cameras can leave the camera out)");
  BagReaderOptions without_cam0;
  without_cam0.cameras = {1, 2};
  BagReader reader(bag, without_cam0);
  EXPECT_EQ(reader.cameraIds(), (std::vector<int>{1, 2}));
}

// Cameras stamped milliseconds apart (cam1 2.5 ms after cam0, cam2 2 ms before it) make one set per
// frame within the tolerance of the set's stamp, the stamp of the image read first (cam2's, the
// earliest); a tolerance below the offsets leaves each camera alone.
TEST_F(BagFiles, BagGroupsCamerasStampedApartWithinTheTolerance) {
  BagWriter writer(path("apart.bag"));
  writer.writeStaticTransforms("world", cameras_, frameTime(0));
  const double offsets[3] = {0.0, 0.0025, -0.002};
  for (int frame = 0; frame < 4; ++frame) {
    for (int id = 0; id < 3; ++id) {
      writer.writeCameraImage(cameras_[id], makeImage(id, frame),
                              frameTime(frame) + ros::Duration(offsets[id]));
    }
  }
  writer.close();
  BagReader reader(path("apart.bag"));
  FrameSet set;
  int sets = 0;
  while (reader.next(&set)) {
    EXPECT_EQ(set.images.size(), 3u) << "set " << sets;
    EXPECT_EQ(set.stamp_ns, (frameTime(sets) - ros::Duration(0.002)).toNSec()) << "set " << sets;
    ++sets;
  }
  EXPECT_EQ(sets, 4);
  EXPECT_EQ(reader.statistics().incomplete_sets, 0u);
  EXPECT_EQ(reader.statistics().tolerated_stamps, 8u);
  EXPECT_NEAR(reader.statistics().largest_stamp_difference, 0.0045, 1e-6);
  BagReaderOptions strict;
  strict.stamp_tolerance = 0.001;
  BagReader apart(path("apart.bag"), strict);
  sets = 0;
  while (apart.next(&set)) {
    EXPECT_EQ(set.images.size(), 1u);
    ++sets;
  }
  EXPECT_EQ(sets, 12);
  EXPECT_GT(apart.statistics().near_stamp_mismatches, 0u);
  BagReaderOptions bad;
  bad.stamp_tolerance = -0.1;
  EXPECT_THROW(BagReader(path("apart.bag"), bad), InputError);
}

TEST(BagConversions, CameraInfoDistortionCounts) {
  sensor_msgs::CameraInfo info = toCameraInfo(makeCamera(1));
  info.D.clear();
  EXPECT_FALSE(fromCameraInfo(info).hasDistortion());
  info.distortion_model.clear();
  EXPECT_FALSE(fromCameraInfo(info).hasDistortion());
  info = toCameraInfo(makeCamera(1));
  info.D.resize(4);
  EXPECT_EQ(fromCameraInfo(info).distortion.size(), 5u);
  info.D = {0.1, 0.2, 0.0};
  const std::string message = sag_test::inputErrorOf([&] { fromCameraInfo(info); });
  EXPECT_EQ(message.rfind("camera 'cam1': camera_info has 3 distortion coefficients", 0), 0u)
      << message;
  // rational_polynomial has 8 coefficients, exactly; plumb_bob 0, 4 or 5.
  info = toCameraInfo(makeCamera(1));
  info.distortion_model = "rational_polynomial";
  for (std::size_t count : {0, 4, 5, 12}) {
    info.D.assign(count, 0.0);
    EXPECT_EQ(sag_test::inputErrorOf([&] { fromCameraInfo(info); }),
              "camera 'cam1': camera_info has " + std::to_string(count) +
                  " distortion coefficients for rational_polynomial (expected 8: k1 k2 p1 p2 k3 "
                  "k4 k5 k6; 5 are plumb_bob's)");
  }
  info.D = {0.01, 0.0, 0.0, 0.0, 0.0, 0.001, 0.0, 0.0};
  EXPECT_EQ(fromCameraInfo(info).distortion, info.D);
  info.distortion_model = "plumb_bob";
  EXPECT_NE(sag_test::inputErrorOf([&] {
              fromCameraInfo(info);
            }).find("has 8 distortion coefficients for plumb_bob (expected 0, 4 or 5)"),
            std::string::npos);
  // Found by fuzz_messages: fx 4.6e-305 was accepted and undistortion gave NaN.
  info = toCameraInfo(makeCamera(1));
  info.K[0] = 4.557446688824057e-305;
  EXPECT_NE(sag_test::inputErrorOf([&] { fromCameraInfo(info); }).find("focal length outside"),
            std::string::npos);
  info = toCameraInfo(makeCamera(1));
  info.K[0] = 1e30;
  EXPECT_NE(sag_test::inputErrorOf([&] {
              fromCameraInfo(info);
            }).find("focal length outside [1, 1e+06] pixels"),
            std::string::npos);
}

TEST(BagConversions, BagCameraInfoRoundTrip) {
  Camera camera = makeCamera(1);
  camera.distortion = {0.1, -0.2, 0.001, 0.002, 0.03, 0.004, 0.005, 0.006};
  const sensor_msgs::CameraInfo info = toCameraInfo(camera);
  EXPECT_EQ(info.header.frame_id, "cam1_optical_frame");
  EXPECT_EQ(info.distortion_model, "rational_polynomial");
  EXPECT_DOUBLE_EQ(info.P[3], 0.0);
  EXPECT_DOUBLE_EQ(info.P[0], camera.K(0, 0));
  const Camera back = fromCameraInfo(info);
  EXPECT_EQ(back.name, "cam1");
  EXPECT_EQ(back.width, camera.width);
  EXPECT_TRUE(back.K.isApprox(camera.K, 0.0));
  EXPECT_EQ(back.distortion, camera.distortion);
  EXPECT_EQ(fromCameraInfo(info, "left").name, "left");

  sensor_msgs::CameraInfo binned = info;
  binned.binning_x = 2;
  EXPECT_THROW(fromCameraInfo(binned), InputError);
  sensor_msgs::CameraInfo fisheye = info;
  fisheye.distortion_model = "equidistant";
  fisheye.D.resize(4);
  EXPECT_THROW(fromCameraInfo(fisheye), InputError);
}

TEST(BagConversions, BagImageAndTransformConversions) {
  const cv::Mat rgb = makeImage(1, 3);
  std_msgs::Header header;
  header.frame_id = "cam1_optical_frame";
  sensor_msgs::Image message = toImageMsg(rgb, header);
  EXPECT_EQ(message.encoding, "rgb8");
  EXPECT_EQ(message.step, 3u * kWidth);
  EXPECT_EQ(message.data[0], rgb.at<cv::Vec3b>(0, 0)[0]);
  EXPECT_TRUE(sameImage(toRgbMat(message), rgb));
  // A padded bgr8 row layout.
  sensor_msgs::Image bgr = message;
  bgr.encoding = "bgr8";
  bgr.step = 3 * kWidth + 4;
  bgr.data.assign(bgr.step * kHeight, 0);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      const cv::Vec3b pixel = rgb.at<cv::Vec3b>(y, x);
      for (int c = 0; c < 3; ++c) bgr.data[y * bgr.step + 3 * x + c] = pixel[2 - c];
    }
  }
  EXPECT_TRUE(sameImage(toRgbMat(bgr), rgb));
  sensor_msgs::Image truncated = message;
  truncated.data.resize(10);
  EXPECT_THROW(toRgbMat(truncated), InputError);
  EXPECT_THROW(toImageMsg(cv::Mat(4, 4, CV_8UC1), header), std::invalid_argument);

  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(2.5, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(-1, 0.5, 2);
  EXPECT_TRUE(toIsometry(toTransformMsg(pose)).matrix().isApprox(pose.matrix(), 1e-12));
  geometry_msgs::Transform bad = toTransformMsg(pose);
  bad.rotation.w *= 2.0;
  EXPECT_THROW(toIsometry(bad), InputError);
  EXPECT_EQ(cameraNameFromFrame("/cam4_optical_frame"), "cam4");
  EXPECT_EQ(cameraNameFromFrame("left_camera"), "left_camera");
}

// The image SoG message carries the segmentation's forearm evidence to the tracker nodelet.
TEST(SogConversions, ForearmEvidenceRoundTripsAndIsValidated) {
  ImageSoG sog;
  sog.width = 640;
  sog.height = 480;
  sog.gaussians.push_back({Eigen::Vector2d(10.0, 20.0), 4.0, Hsv(20.0, 0.4, 0.8)});
  sog.arm_cells = 57;
  sog.arm_centroid = Eigen::Vector2d(312.5, 401.0);
  sog.arm_gaussians.push_back({Eigen::Vector2d(310.0, 402.0), 1.6, Hsv::Zero()});
  sog.arm_gaussians.push_back({Eigen::Vector2d(314.0, 402.0), 1.6, Hsv::Zero()});
  sag_hand_tracker::SumOfGaussians msg = sogToMsg(sog);
  const ImageSoG back = sogFromMsg(msg);
  EXPECT_EQ(back.arm_cells, 57);
  EXPECT_NEAR(back.arm_centroid.x(), 312.5, 1e-3);
  EXPECT_NEAR(back.arm_centroid.y(), 401.0, 1e-3);
  ASSERT_EQ(back.gaussians.size(), 1u);
  ASSERT_EQ(back.arm_gaussians.size(), 2u);  // the sleeve's cells (silhouette.h)
  EXPECT_NEAR(back.arm_gaussians[1].mean.x(), 314.0, 1e-3);
  EXPECT_NEAR(back.arm_gaussians[1].sigma, 1.6, 1e-6);

  auto rejects = [](const sag_hand_tracker::SumOfGaussians& bad, const std::string& words) {
    try {
      sogFromMsg(bad);
      ADD_FAILURE() << "accepted: " << words;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  sag_hand_tracker::SumOfGaussians bad = msg;
  bad.arm_gaussians[1].sigma = 0.0f;
  rejects(bad, "sleeve Gaussian 1");
  bad = msg;
  bad.arm_cells = 0;  // cells without the count
  rejects(bad, "arm_cells 0");

  msg.arm_x = std::numeric_limits<float>::quiet_NaN();
  try {
    sogFromMsg(msg);
    FAIL() << "a NaN forearm centroid was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("forearm"), std::string::npos) << e.what();
  }
  sog.arm_cells = 0;  // no evidence: the centroid is not looked at
  msg = sogToMsg(sog);
  msg.arm_x = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(sogFromMsg(msg).arm_cells, 0);
}

// Length prefixes checked before roscpp allocates what they declare (ros/message_bounds.h).
namespace {

template <class M>
std::vector<std::uint8_t> serialized(const M& message) {
  std::vector<std::uint8_t> bytes(ros::serialization::serializationLength(message));
  ros::serialization::OStream stream(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::serialize(stream, message);
  return bytes;
}

template <class M>
std::string check(const std::vector<std::uint8_t>& bytes) {
  return checkSerializedMessage(ros::message_traits::datatype<M>(),
                                ros::message_traits::definition<M>(), bytes.data(), bytes.size());
}

void writeUint32(std::vector<std::uint8_t>* bytes, std::size_t offset, std::uint32_t value) {
  std::memcpy(bytes->data() + offset, &value, 4);
}

}  // namespace

TEST(MessageBounds, WellFormedMessagesPass) {
  sensor_msgs::CameraInfo info;
  info.header.frame_id = "cam0_optical";
  info.distortion_model = "plumb_bob";
  info.D = {0.1, 0.0, 0.0, 0.0, 0.0};
  EXPECT_EQ(check<sensor_msgs::CameraInfo>(serialized(info)), "");
  sensor_msgs::Image image;
  image.encoding = "rgb8";
  image.data.assign(12, 7);
  EXPECT_EQ(check<sensor_msgs::Image>(serialized(image)), "");
  tf2_msgs::TFMessage tf;
  tf.transforms.resize(2);
  tf.transforms[1].child_frame_id = "cam1";
  EXPECT_EQ(check<tf2_msgs::TFMessage>(serialized(tf)), "");
}

namespace {

// A small well-formed CameraInfo, and where its serialized D array's length prefix sits.
sensor_msgs::CameraInfo smallCameraInfo() {
  sensor_msgs::CameraInfo info;
  info.header.frame_id = "f";
  info.distortion_model = "plumb_bob";
  info.D = {0.1, 0.0, 0.0, 0.0, 0.0};
  return info;
}
// header: seq, stamp (8), frame_id (4 + 1); height, width; distortion_model (4 + 9); then D.
constexpr std::size_t kSmallCameraInfoDOffset = 4 + 8 + 4 + 1 + 4 + 4 + 4 + 9;

}  // namespace

TEST(MessageBounds, AnArrayLongerThanTheMessageIsNamed) {
  const sensor_msgs::CameraInfo info = smallCameraInfo();
  std::vector<std::uint8_t> bytes = serialized(info);
  const std::size_t d_offset = kSmallCameraInfoDOffset;
  std::uint32_t declared = 0;
  std::memcpy(&declared, bytes.data() + d_offset, 4);
  ASSERT_EQ(declared, 5u);
  writeUint32(&bytes, d_offset, 1800000000u);
  const std::string problem = check<sensor_msgs::CameraInfo>(bytes);
  EXPECT_NE(problem.find("D: 1800000000 elements of 8 bytes declared"), std::string::npos)
      << problem;

  sensor_msgs::Image image;
  image.encoding = "rgb8";
  image.data.assign(12, 7);
  std::vector<std::uint8_t> image_bytes = serialized(image);
  writeUint32(&image_bytes, image_bytes.size() - 12 - 4, 0xFFFFFFF0u);
  EXPECT_NE(check<sensor_msgs::Image>(image_bytes).find("data:"), std::string::npos);

  tf2_msgs::TFMessage tf;
  tf.transforms.resize(1);
  std::vector<std::uint8_t> tf_bytes = serialized(tf);
  writeUint32(&tf_bytes, 0, 100000000u);
  EXPECT_NE(check<tf2_msgs::TFMessage>(tf_bytes).find("transforms: 100000000 elements"),
            std::string::npos);
}

TEST(MessageBounds, TruncatedAndOverlongMessagesAreRefused) {
  sensor_msgs::CameraInfo info;
  info.D = {0.1, 0.0, 0.0, 0.0, 0.0};
  std::vector<std::uint8_t> bytes = serialized(info);
  std::vector<std::uint8_t> truncated(bytes.begin(), bytes.end() - 3);
  EXPECT_NE(check<sensor_msgs::CameraInfo>(truncated), "");
  std::vector<std::uint8_t> overlong = bytes;
  overlong.push_back(0);
  EXPECT_NE(check<sensor_msgs::CameraInfo>(overlong).find("1 bytes left over"), std::string::npos);
  EXPECT_NE(checkSerializedMessage("pkg/Unknown", "Other x\n", bytes.data(), bytes.size())
                .find("unknown type pkg/Other"),
            std::string::npos);
}

// The fuzzer's finding: a bag whose camera_info declares 1.8e9 distortion coefficients made roscpp
// allocate 14.7 GB; it is now refused with the topic and the field.
TEST(MessageBounds, TheBagWithAHugeDeclaredArrayIsRefusedWithoutAllocatingIt) {
  const std::string bag = corpusBag("crash_camera_info_huge_array_length");
  try {
    BagReader reader(bag);
    FAIL() << "the bag was accepted";
  } catch (const InputError& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("/cam1/camera_info"), std::string::npos) << message;
    EXPECT_NE(message.find("malformed sensor_msgs/CameraInfo message (D: 1836412016 elements"),
              std::string::npos)
        << message;
  }
}

// The live subscriptions (ros/checked_subscription.h): roscpp hands the helper the bytes of a
// message from another process; a well-formed one reaches the callback unchanged, a malformed one
// is reported and never deserialized (the callback is not called).
TEST(MessageBounds, LiveSubscriptionsDropMalformedMessagesBeforeDeserializing) {
  const sensor_msgs::CameraInfo info = smallCameraInfo();
  std::vector<std::uint8_t> bytes = serialized(info);
  int calls = 0;
  std::vector<std::string> problems;
  CheckedCallbackHelper<sensor_msgs::CameraInfo> helper(
      [&](const sensor_msgs::CameraInfo::ConstPtr&) { ++calls; },
      [&](const std::string& problem) { problems.push_back(problem); });
  auto deserialize = [&](std::vector<std::uint8_t>* data) {
    ros::SubscriptionCallbackHelperDeserializeParams params;
    params.buffer = data->data();
    params.length = static_cast<std::uint32_t>(data->size());
    return helper.deserialize(params);
  };
  const ros::VoidConstPtr good = deserialize(&bytes);
  ASSERT_TRUE(good);
  const auto* message = static_cast<const sensor_msgs::CameraInfo*>(good.get());
  EXPECT_EQ(message->D, info.D);
  EXPECT_EQ(message->header.frame_id, "f");
  EXPECT_TRUE(problems.empty());

  writeUint32(&bytes, kSmallCameraInfoDOffset, 1800000000u);
  EXPECT_FALSE(deserialize(&bytes));
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("D: 1800000000 elements of 8 bytes declared"), std::string::npos)
      << problems[0];
  bytes.resize(10);  // truncated
  EXPECT_FALSE(deserialize(&bytes));
  EXPECT_EQ(problems.size(), 2u);
  EXPECT_EQ(calls, 0);  // deserialize never calls back; roscpp calls only with a message
}
