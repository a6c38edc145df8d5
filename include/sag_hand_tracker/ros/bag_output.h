// Writing multi-camera bags in the interface that BagReader (and track_bag) reads: per camera
// /<name>/image_raw and /<name>/camera_info with identical stamps, and the rig's extrinsics on
// /tf_static. Cameras should be named cam<i> (doc/design.md section 6). No ROS master needed.
#pragma once

#include <ros/time.h>
#include <rosbag/bag.h>

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/tracking/frame_set.h"

namespace sag_hand_tracker {

enum class BagCompression { kNone, kLz4, kBz2 };

// The topics of a camera: "/<name>/image_raw" and "/<name>/camera_info".
std::string imageTopicOf(const Camera& camera);
std::string cameraInfoTopicOf(const Camera& camera);

class BagWriter {
 public:
  // Creates (overwrites) the bag. Throws InputError naming the file if it cannot.
  explicit BagWriter(const std::string& path, BagCompression compression = BagCompression::kNone);
  ~BagWriter();
  BagWriter(const BagWriter&) = delete;
  BagWriter& operator=(const BagWriter&) = delete;

  // One tf2_msgs/TFMessage on /tf_static with root_frame -> <name>_optical_frame for every camera
  // (the inverse of Camera::world_to_camera), stamped `stamp`.
  void writeStaticTransforms(const std::string& root_frame, const std::vector<Camera>& cameras,
                             const ros::Time& stamp);
  void writeStaticTransforms(const CameraRig& rig, const ros::Time& stamp);

  // One camera's image (CV_8UC3, RGB) and its camera_info, both with header stamp `stamp` and
  // frame_id <name>_optical_frame, recorded at `stamp`. `encoding` is "rgb8" or "bgr8" (the bytes
  // are reordered for bgr8). Throws std::invalid_argument for another encoding, another image
  // type, or an image whose size is not the camera's.
  void writeCameraImage(const Camera& camera, const cv::Mat& rgb, const ros::Time& stamp,
                        const std::string& encoding = "rgb8");

  // Every image of a set: images[k].camera indexes `cameras`; the stamp is the set's.
  void writeFrameSet(const std::vector<Camera>& cameras, const FrameSet& set,
                     const std::string& encoding = "rgb8");

  // Any message (ground truth, or a deliberately malformed input in a test), recorded at `time`.
  template <class Message>
  void write(const std::string& topic, const ros::Time& time, const Message& message) {
    try {
      bag_.write(topic, time, message);
    } catch (const rosbag::BagException& error) {
      fail(error.what());
    }
  }

  // Closes the bag (also done by the destructor). Throws InputError on a write error.
  void close();
  const std::string& path() const { return path_; }

 private:
  [[noreturn]] void fail(const std::string& problem) const;

  std::string path_;
  rosbag::Bag bag_;
};

}  // namespace sag_hand_tracker
