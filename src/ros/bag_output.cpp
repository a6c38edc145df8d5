#include "sag_hand_tracker/ros/bag_output.h"

#include <rosbag/exceptions.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_msgs/TFMessage.h>

#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "sag_hand_tracker/ros/conversions.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

std::string imageTopicOf(const Camera& camera) { return "/" + camera.name + "/image_raw"; }
std::string cameraInfoTopicOf(const Camera& camera) { return "/" + camera.name + "/camera_info"; }

BagWriter::BagWriter(const std::string& path, BagCompression compression) : path_(path) {
  try {
    bag_.open(path, rosbag::bagmode::Write);
    switch (compression) {
      case BagCompression::kNone:
        bag_.setCompression(rosbag::compression::Uncompressed);
        break;
      case BagCompression::kLz4:
        bag_.setCompression(rosbag::compression::LZ4);
        break;
      case BagCompression::kBz2:
        bag_.setCompression(rosbag::compression::BZ2);
        break;
    }
  } catch (const rosbag::BagException& error) {
    fail(std::string("cannot create the bag: ") + error.what());
  }
}

BagWriter::~BagWriter() {
  try {
    bag_.close();
  } catch (const rosbag::BagException&) {
  }
}

void BagWriter::fail(const std::string& problem) const { throw InputError(path_ + ": " + problem); }

void BagWriter::writeStaticTransforms(const std::string& root_frame,
                                      const std::vector<Camera>& cameras, const ros::Time& stamp) {
  tf2_msgs::TFMessage message;
  for (const Camera& camera : cameras) {
    geometry_msgs::TransformStamped transform;
    transform.header.stamp = stamp;
    transform.header.frame_id = root_frame;
    transform.child_frame_id = opticalFrame(camera.name);
    transform.transform = toTransformMsg(camera.world_to_camera.inverse());
    message.transforms.push_back(transform);
  }
  write("/tf_static", stamp, message);
}

void BagWriter::writeStaticTransforms(const CameraRig& rig, const ros::Time& stamp) {
  writeStaticTransforms(rig.root_frame, rig.cameras, stamp);
}

void BagWriter::writeCameraImage(const Camera& camera, const cv::Mat& rgb, const ros::Time& stamp,
                                 const std::string& encoding) {
  if (rgb.cols != camera.width || rgb.rows != camera.height) {
    throw std::invalid_argument("BagWriter: image of camera '" + camera.name + "' is " +
                                std::to_string(rgb.cols) + "x" + std::to_string(rgb.rows) +
                                ", the camera's " + std::to_string(camera.width) + "x" +
                                std::to_string(camera.height));
  }
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = opticalFrame(camera.name);
  sensor_msgs::Image image;
  if (encoding == sensor_msgs::image_encodings::RGB8) {
    image = toImageMsg(rgb, header);
  } else if (encoding == sensor_msgs::image_encodings::BGR8) {
    cv::Mat bgr;
    cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
    image = toImageMsg(bgr, header);
    image.encoding = sensor_msgs::image_encodings::BGR8;
  } else {
    throw std::invalid_argument("BagWriter: encoding '" + encoding + "' (rgb8 or bgr8)");
  }
  sensor_msgs::CameraInfo info = toCameraInfo(camera);
  info.header = header;
  write(imageTopicOf(camera), stamp, image);
  write(cameraInfoTopicOf(camera), stamp, info);
}

void BagWriter::writeFrameSet(const std::vector<Camera>& cameras, const FrameSet& set,
                              const std::string& encoding) {
  ros::Time stamp;
  stamp.fromNSec(static_cast<std::uint64_t>(set.stamp_ns));
  for (const CameraImage& image : set.images) {
    if (image.camera < 0 || image.camera >= static_cast<int>(cameras.size())) {
      throw std::invalid_argument("BagWriter: camera index " + std::to_string(image.camera) +
                                  " out of range");
    }
    writeCameraImage(cameras[image.camera], image.rgb, stamp, encoding);
  }
}

void BagWriter::close() {
  try {
    bag_.close();
  } catch (const rosbag::BagException& error) {
    fail(std::string("cannot write the bag: ") + error.what());
  }
}

}  // namespace sag_hand_tracker
