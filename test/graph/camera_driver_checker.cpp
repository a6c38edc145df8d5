// gtest node of test/rostest/camera_driver.test: writes image folders, calibration files and a rig
// file to a temporary folder, loads sag_hand_tracker/CameraDriverNodelet into the test's nodelet
// manager (/manager) with parameters pointing at them, and checks what the driver publishes and
// logs:
//   Folders: three sources, one of them missing (an ERROR names it, the other two publish); sets
//     stamped with one stamp; rgb8 at the width x height parameters (one folder is resized);
//     images in sorted file order, looping; camera_info from a file:// url and from the rig file;
//     a camera_info size mismatch warned; the rig's extrinsics on /tf_static.
//   FolderRunsOut: loop false, custom camera names; the short folder's end is reported once as
//     an ERROR and the other camera keeps publishing until its own end.
#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <nodelet/NodeletLoad.h>
#include <nodelet/NodeletUnload.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <Eigen/Geometry>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <set>

namespace fs = std::filesystem;

namespace {

const int kWidth = 64;
const int kHeight = 48;

// The temporary folder of the test run, removed at the end.
class TempDir {
 public:
  TempDir() {
    std::random_device random;
    path_ = fs::temp_directory_path() / ("sag_camera_driver_test_" + std::to_string(random()));
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string operator/(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

// A folder of `count` images "frame_<i>.png" of the given size; image i is uniformly
// BGR (blue, step * i, red), so its index can be read back from the green channel.
std::string writeFolder(const std::string& folder, int count, int width, int height, int blue,
                        int red, int step) {
  fs::create_directories(folder);
  for (int i = 0; i < count; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "frame_%03d.png", i);
    cv::imwrite((fs::path(folder) / name).string(),
                cv::Mat(height, width, CV_8UC3, cv::Scalar(blue, step * i, red)));
  }
  std::ofstream(fs::path(folder) / "notes.txt") << "not an image: skipped\n";
  return folder;
}

// A camera_calibration_parsers file.
void writeCalibration(const std::string& path, const std::string& name, int width, int height,
                      double f) {
  const double cx = width / 2.0, cy = height / 2.0;
  std::ofstream out(path);
  out << "image_width: " << width << "\nimage_height: " << height << "\ncamera_name: " << name
      << "\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: [" << f << ", 0, " << cx << ", 0, " << f
      << ", " << cy << ", 0, 0, 1]\n"
      << "distortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n"
      << "  data: [0, 0, 0, 0, 0]\n"
      << "rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
      << "projection_matrix:\n  rows: 3\n  cols: 4\n  data: [" << f << ", 0, " << cx << ", 0, 0, "
      << f << ", " << cy << ", 0, 0, 0, 1, 0]\n";
}

struct Received {
  std::vector<sensor_msgs::Image> images;
  std::vector<sensor_msgs::CameraInfo> infos;
};

// Everything the checker hears, by topic, plus /rosout.
class Recorder {
 public:
  explicit Recorder(const std::vector<std::string>& camera_namespaces) {
    ros::NodeHandle nh;
    for (const std::string& ns : camera_namespaces) {
      subs_.push_back(nh.subscribe<sensor_msgs::Image>(
          ns + "/image_raw", 200, [this, ns](const sensor_msgs::Image::ConstPtr& m) {
            std::lock_guard<std::mutex> lock(mutex_);
            cameras_[ns].images.push_back(*m);
          }));
      subs_.push_back(nh.subscribe<sensor_msgs::CameraInfo>(
          ns + "/camera_info", 200, [this, ns](const sensor_msgs::CameraInfo::ConstPtr& m) {
            std::lock_guard<std::mutex> lock(mutex_);
            cameras_[ns].infos.push_back(*m);
          }));
    }
    rosout_ = nh.subscribe<rosgraph_msgs::Log>("/rosout", 1000,
                                               [this](const rosgraph_msgs::Log::ConstPtr& m) {
                                                 std::lock_guard<std::mutex> lock(mutex_);
                                                 logs_.push_back(*m);
                                               });
  }

  // Waits until /rosout is connected to the manager (the checker itself is one publisher).
  bool waitForRosout() const {
    const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(10.0);
    while (ros::WallTime::now() < until) {
      if (rosout_.getNumPublishers() >= 2) return true;
      ros::WallDuration(0.05).sleep();
    }
    return false;
  }

  Received camera(const std::string& ns) {
    std::lock_guard<std::mutex> lock(mutex_);
    return cameras_[ns];
  }

  // The first /rosout message of at least `level` containing `text`, if any.
  bool findLog(std::uint8_t level, const std::string& text, rosgraph_msgs::Log* found = nullptr,
               int* count = nullptr) {
    std::lock_guard<std::mutex> lock(mutex_);
    bool any = false;
    if (count) *count = 0;
    for (const rosgraph_msgs::Log& log : logs_) {
      if (log.level < level || log.msg.find(text) == std::string::npos) continue;
      if (!any && found) *found = log;
      any = true;
      if (count) ++*count;
    }
    return any;
  }

  std::string allLogs() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::string text;
    for (const rosgraph_msgs::Log& log : logs_) {
      text += "  [" + std::to_string(log.level) + "] " + log.msg + "\n";
    }
    return text;
  }

 private:
  std::mutex mutex_;
  std::map<std::string, Received> cameras_;
  std::vector<rosgraph_msgs::Log> logs_;
  std::vector<ros::Subscriber> subs_;
  ros::Subscriber rosout_;
};

bool loadDriver(const std::string& name) {
  nodelet::NodeletLoad load;
  load.request.name = name;
  load.request.type = "sag_hand_tracker/CameraDriverNodelet";
  if (!ros::service::waitForService("/manager/load_nodelet", ros::Duration(20.0))) return false;
  return ros::service::call("/manager/load_nodelet", load) && load.response.success;
}

void unloadDriver(const std::string& name) {
  nodelet::NodeletUnload unload;
  unload.request.name = name;
  ros::service::call("/manager/unload_nodelet", unload);
}

// Green value of the first pixel of an rgb8 image.
int green(const sensor_msgs::Image& image) { return image.data.at(1); }

void expectImageFormat(const sensor_msgs::Image& image, const std::string& frame_id) {
  EXPECT_EQ(image.encoding, "rgb8");
  EXPECT_EQ(image.width, static_cast<unsigned>(kWidth));
  EXPECT_EQ(image.height, static_cast<unsigned>(kHeight));
  EXPECT_EQ(image.step, static_cast<unsigned>(kWidth * 3));
  EXPECT_EQ(image.data.size(), static_cast<std::size_t>(kWidth * kHeight * 3));
  EXPECT_EQ(image.header.frame_id, frame_id);
}

void expectStampsIncrease(const std::vector<sensor_msgs::Image>& images) {
  for (std::size_t i = 1; i < images.size(); ++i) {
    EXPECT_GT(images[i].header.stamp, images[i - 1].header.stamp) << "image " << i;
  }
}

// The images that share a stamp with an image of `other`, keyed by stamp.
std::map<ros::Time, std::pair<const sensor_msgs::Image*, const sensor_msgs::Image*>> pairByStamp(
    const std::vector<sensor_msgs::Image>& a, const std::vector<sensor_msgs::Image>& b) {
  std::map<ros::Time, const sensor_msgs::Image*> by_stamp;
  for (const auto& image : b) by_stamp[image.header.stamp] = &image;
  std::map<ros::Time, std::pair<const sensor_msgs::Image*, const sensor_msgs::Image*>> pairs;
  for (const auto& image : a) {
    auto it = by_stamp.find(image.header.stamp);
    if (it != by_stamp.end()) pairs[image.header.stamp] = {&image, it->second};
  }
  return pairs;
}

TEST(CameraDriver, Folders) {
  TempDir dir;
  // cam0: 4 images at the output size, red; cam1: 4 images at 80x60 (resized), blue.
  const std::string good0 = writeFolder(dir / "good0", 4, kWidth, kHeight, 0, 255, 10);
  const std::string good1 = writeFolder(dir / "good1", 4, 80, 60, 255, 0, 10);
  const std::string missing = dir / "missing";
  writeCalibration(dir / "from_url_cam0.yaml", "cam0", kWidth, kHeight, 55.0);
  fs::create_directories(dir / "rig");
  writeCalibration(dir / "rig/cam0.yaml", "cam0", kWidth, kHeight, 50.0);
  writeCalibration(dir / "rig/cam1.yaml", "cam1", 80, 60, 70.0);  // not the image size
  std::ofstream(dir / "rig/rig.yaml")
      << "root_frame: studio\ncameras:\n"
      << "  - name: cam0\n    calibration: cam0.yaml\n    translation: [0.1, -0.2, 0.75]\n"
      << "    rotation: [0.0, 0.7071067811865476, 0.0, 0.7071067811865476]\n"
      << "  - name: cam1\n    calibration: cam1.yaml\n    translation: [-0.5, 0.25, 1.0]\n"
      << "    rotation: [0.5, 0.5, 0.5, 0.5]\n";

  ros::NodeHandle driver("/a/driver");
  driver.setParam("sources",
                  std::vector<std::string>{"dir:" + good0, "dir:" + good1, "dir:" + missing});
  driver.setParam("camera_info_urls",
                  std::vector<std::string>{"file://" + (dir / "from_url_cam0.yaml"), "",
                                           "file://" + (dir / "no_such_calibration.yaml")});
  driver.setParam("rig_file", dir / "rig/rig.yaml");
  driver.setParam("width", kWidth);
  driver.setParam("height", kHeight);
  driver.setParam("fps", 20.0);
  driver.setParam("loop", true);

  Recorder rec({"/a/cam0", "/a/cam1", "/a/cam2"});
  ros::AsyncSpinner spinner(2);
  spinner.start();
  ASSERT_TRUE(rec.waitForRosout()) << "/rosout of the manager not connected";
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);

  ASSERT_TRUE(loadDriver("/a/driver")) << "the manager did not load the driver";
  ros::WallDuration(4.0).sleep();
  unloadDriver("/a/driver");

  // The missing folder: an ERROR naming the camera and the folder; no images from it.
  EXPECT_TRUE(rec.findLog(rosgraph_msgs::Log::ERROR,
                          "camera cam2: image folder '" + missing + "' does not exist"))
      << rec.allLogs();
  EXPECT_TRUE(rec.camera("/a/cam2").images.empty());
  EXPECT_TRUE(
      rec.findLog(rosgraph_msgs::Log::ERROR,
                  "camera cam2: no calibration could be read from camera_info_url 'file://" +
                      (dir / "no_such_calibration.yaml") + "'"))
      << rec.allLogs();

  const Received cam0 = rec.camera("/a/cam0");
  const Received cam1 = rec.camera("/a/cam1");
  ASSERT_GE(cam0.images.size(), 20u) << rec.allLogs();  // 80 sets at 20 fps in 4 s
  ASSERT_GE(cam1.images.size(), 20u);
  for (const auto& image : cam0.images) {
    expectImageFormat(image, "cam0_optical_frame");
    EXPECT_EQ(image.data[0], 255);  // R: the folder's BGR images come out as RGB
    EXPECT_EQ(image.data[2], 0);
  }
  for (const auto& image : cam1.images) {
    expectImageFormat(image, "cam1_optical_frame");
    EXPECT_EQ(image.data[0], 0);
    EXPECT_EQ(image.data[2], 255);
  }
  expectStampsIncrease(cam0.images);
  expectStampsIncrease(cam1.images);
  // Sorted order, looping: the green channel counts 0, 10, 20, 30, 0, ...
  for (std::size_t i = 1; i < cam0.images.size(); ++i) {
    EXPECT_EQ(green(cam0.images[i]), (green(cam0.images[i - 1]) + 10) % 40) << "image " << i;
  }

  // One stamp per set: both cameras' images of a set carry the same stamp and come from the same
  // position in their folders.
  const auto pairs = pairByStamp(cam0.images, cam1.images);
  // (the two subscriptions may connect a set apart, at the start and at the unload)
  EXPECT_GE(pairs.size() + 4, std::min(cam0.images.size(), cam1.images.size()))
      << "images of the two cameras do not share their stamps";
  for (const auto& [stamp, pair] : pairs) {
    EXPECT_EQ(green(*pair.first), green(*pair.second)) << "set " << stamp;
  }
  EXPECT_TRUE(rec.findLog(
      rosgraph_msgs::Log::WARN,
      "camera cam1 (image folder '" + good1 + "') delivers 80x60 frames; resizing them to 64x48"));
  int resize_warnings = 0;
  rec.findLog(rosgraph_msgs::Log::WARN, "resizing them", nullptr, &resize_warnings);
  EXPECT_EQ(resize_warnings, 1) << "warned once, for cam1 only";

  // camera_info: cam0 from its file:// url (f = 55, not the rig's 50), cam1 from the rig file.
  ASSERT_FALSE(cam0.infos.empty());
  ASSERT_FALSE(cam1.infos.empty());
  std::set<ros::Time> image_stamps;
  for (const auto& image : cam0.images) image_stamps.insert(image.header.stamp);
  for (const auto& info : cam0.infos) {
    EXPECT_DOUBLE_EQ(info.K[0], 55.0);
    EXPECT_DOUBLE_EQ(info.K[2], kWidth / 2.0);
    EXPECT_EQ(info.width, static_cast<unsigned>(kWidth));
    EXPECT_EQ(info.height, static_cast<unsigned>(kHeight));
    EXPECT_EQ(info.header.frame_id, "cam0_optical_frame");
  }
  int info_stamps_matched = 0;
  for (const auto& info : cam0.infos) info_stamps_matched += image_stamps.count(info.header.stamp);
  EXPECT_GE(info_stamps_matched + 2, static_cast<int>(cam0.infos.size()));
  // cam1's calibration is for 80x60 but its frames are resized to 64x48: camera_info is rescaled
  // (scaleIntrinsics: f * 0.8, c' = (c + 1/2) * 0.8 - 1/2), logged once; same aspect, no WARN.
  for (const auto& info : cam1.infos) {
    EXPECT_DOUBLE_EQ(info.K[0], 56.0);
    EXPECT_DOUBLE_EQ(info.K[2], 40.5 * 0.8 - 0.5);
    EXPECT_DOUBLE_EQ(info.P[0], 56.0);
    EXPECT_EQ(info.width, 64u);
    EXPECT_EQ(info.height, 48u);
    EXPECT_EQ(info.header.frame_id, "cam1_optical_frame");
  }
  int rescale_logs = 0;
  rec.findLog(rosgraph_msgs::Log::INFO,
              "camera cam1: camera_info calibrated at 80x60, rescaled (K, P) to the 64x48 images",
              nullptr, &rescale_logs);
  EXPECT_EQ(rescale_logs, 1) << "logged once";
  int info_warnings = 0;
  rec.findLog(rosgraph_msgs::Log::WARN, "camera_info is for", nullptr, &info_warnings);
  EXPECT_EQ(info_warnings, 0) << "same aspect ratio: no warning";
  EXPECT_TRUE(rec.findLog(rosgraph_msgs::Log::WARN,
                          "camera cam2 is not in the rig file: no extrinsics published for it"));

  // Extrinsics: static tf studio -> cam<i>_optical_frame, exactly the rig's.
  const struct {
    const char* frame;
    Eigen::Vector3d t;
    Eigen::Quaterniond q;
  } expected[] = {
      // Eigen's quaternion constructor takes (w, x, y, z).
      {"cam0_optical_frame", {0.1, -0.2, 0.75}, {0.7071067811865476, 0, 0.7071067811865476, 0}},
      {"cam1_optical_frame", {-0.5, 0.25, 1.0}, {0.5, 0.5, 0.5, 0.5}},
  };
  for (const auto& e : expected) {
    geometry_msgs::TransformStamped tf;
    try {
      tf = tf_buffer.lookupTransform("studio", e.frame, ros::Time(0), ros::Duration(5.0));
    } catch (const std::exception& error) {
      ADD_FAILURE() << "no tf studio -> " << e.frame << ": " << error.what();
      continue;
    }
    EXPECT_NEAR(tf.transform.translation.x, e.t.x(), 1e-9) << e.frame;
    EXPECT_NEAR(tf.transform.translation.y, e.t.y(), 1e-9) << e.frame;
    EXPECT_NEAR(tf.transform.translation.z, e.t.z(), 1e-9) << e.frame;
    const Eigen::Quaterniond q(tf.transform.rotation.w, tf.transform.rotation.x,
                               tf.transform.rotation.y, tf.transform.rotation.z);
    EXPECT_NEAR(std::abs(q.dot(e.q)), 1.0, 1e-9) << e.frame;
  }
  EXPECT_FALSE(tf_buffer.canTransform("studio", "cam2_optical_frame", ros::Time(0)));
  spinner.stop();
}

TEST(CameraDriver, FolderRunsOut) {
  TempDir dir;
  const int step = 4;
  const std::string long_folder = writeFolder(dir / "long", 50, kWidth, kHeight, 0, 255, step);
  const std::string short_folder = writeFolder(dir / "short", 8, kWidth, kHeight, 0, 255, step);

  ros::NodeHandle driver("/b/driver");
  driver.setParam("sources", std::vector<std::string>{"dir:" + long_folder, "dir:" + short_folder});
  driver.setParam("camera_names", std::vector<std::string>{"left", "right"});
  driver.setParam("width", kWidth);
  driver.setParam("height", kHeight);
  driver.setParam("fps", 10.0);
  driver.setParam("loop", false);

  Recorder rec({"/b/left", "/b/right"});
  ros::AsyncSpinner spinner(2);
  spinner.start();
  ASSERT_TRUE(rec.waitForRosout()) << "/rosout of the manager not connected";
  ASSERT_TRUE(loadDriver("/b/driver")) << "the manager did not load the driver";

  // 50 sets at 10 fps: the long folder ends after 5 s; wait for the driver to say so.
  const std::string all_done = "no camera is delivering any more";
  const ros::WallTime until = ros::WallTime::now() + ros::WallDuration(15.0);
  while (ros::WallTime::now() < until && !rec.findLog(rosgraph_msgs::Log::ERROR, all_done)) {
    ros::WallDuration(0.1).sleep();
  }
  ros::WallDuration(0.3).sleep();
  unloadDriver("/b/driver");
  spinner.stop();

  rosgraph_msgs::Log short_end;
  int short_end_count = 0;
  ASSERT_TRUE(rec.findLog(rosgraph_msgs::Log::ERROR,
                          "camera right (image folder '" + short_folder +
                              "') has no more frames: all 8 images read (loop is off)",
                          &short_end, &short_end_count))
      << rec.allLogs();
  EXPECT_EQ(short_end_count, 1) << "reported once";
  int long_end_count = 0;
  EXPECT_TRUE(rec.findLog(rosgraph_msgs::Log::ERROR,
                          "camera left (image folder '" + long_folder +
                              "') has no more frames: all 50 images read (loop is off)",
                          nullptr, &long_end_count))
      << rec.allLogs();
  EXPECT_EQ(long_end_count, 1);
  EXPECT_TRUE(rec.findLog(rosgraph_msgs::Log::ERROR, all_done));

  const Received left = rec.camera("/b/left");
  const Received right = rec.camera("/b/right");
  // The first images may be published before the subscription is connected; the last are not.
  ASSERT_GE(right.images.size(), 4u);
  ASSERT_LE(right.images.size(), 8u);
  EXPECT_EQ(green(right.images.back()), 7 * step) << "the short folder's last image";
  ASSERT_GE(left.images.size(), 40u);
  EXPECT_EQ(green(left.images.back()), 49 * step) << "the long folder's last image";
  for (const auto& image : left.images) expectImageFormat(image, "left_optical_frame");
  for (const auto& image : right.images) expectImageFormat(image, "right_optical_frame");
  expectStampsIncrease(left.images);
  // While both ran, their sets shared stamps.
  const auto pairs = pairByStamp(left.images, right.images);
  EXPECT_GE(pairs.size() + 1, right.images.size());
  for (const auto& [stamp, pair] : pairs) EXPECT_EQ(green(*pair.first), green(*pair.second));

  // The other camera kept publishing after the short folder's end was reported.
  int after = 0;
  for (const auto& image : left.images) after += image.header.stamp > short_end.header.stamp;
  EXPECT_GE(after, 30) << "left stopped with right";

  // No calibration anywhere: an uncalibrated camera_info that still gives the image size.
  ASSERT_FALSE(left.infos.empty());
  EXPECT_EQ(left.infos.back().width, static_cast<unsigned>(kWidth));
  EXPECT_EQ(left.infos.back().height, static_cast<unsigned>(kHeight));
  EXPECT_EQ(left.infos.back().K[0], 0.0);
  EXPECT_TRUE(rec.findLog(rosgraph_msgs::Log::WARN, "camera left is not calibrated"));
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "camera_driver_checker");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
