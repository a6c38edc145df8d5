// Conversions between ROS messages and the core types: cameras, images and rigid transforms.
// Used by the bag tools and the nodelets. Bad input throws sag_hand_tracker::InputError with a
// one-line message.
#pragma once

#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/Transform.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/JointState.h>
#include <std_msgs/Header.h>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <string>

#include "sag_hand_tracker/apps/metrics.h"
#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/model/pose.h"

namespace sag_hand_tracker {

// The camera name of an optical frame: "cam0_optical_frame" -> "cam0"; other ids unchanged.
std::string cameraNameFromFrame(const std::string& frame_id);

// CameraInfo of a camera: K, D (plumb_bob, or rational_polynomial for more than 5 coefficients),
// R = I, P = [K | 0], size, and header.frame_id = "<name>_optical_frame". The stamp is left zero.
sensor_msgs::CameraInfo toCameraInfo(const Camera& camera);

// The camera of a CameraInfo (through image_geometry::PinholeCameraModel). The name is
// `camera_name`, or the frame id without "_optical_frame" when `camera_name` is empty;
// world_to_camera is the identity (extrinsics come from tf). Throws InputError naming the camera
// for: zero or negative focal length, zero image size, a distortion model other than plumb_bob
// and rational_polynomial, binning or a region of interest (not supported).
Camera fromCameraInfo(const sensor_msgs::CameraInfo& info, const std::string& camera_name = "");

// An rgb8 image message of a CV_8UC3 RGB image (deep copy). Throws std::invalid_argument for
// any other cv::Mat type.
sensor_msgs::Image toImageMsg(const cv::Mat& rgb, const std_msgs::Header& header);

// Whether the tracker can read an image of this encoding (rgb8 and bgr8).
bool isSupportedEncoding(const std::string& encoding);

// What is wrong with the layout of a 3-byte-per-pixel image message, or "" when nothing is: its
// data must be exactly step x height bytes with step >= width x 3, e.g. "malformed image: 230500
// bytes for 320x240 with step 960, not step x height = 230400". The bag
// reader (through toRgbMat) and the live segmentation refuse such messages alike.
std::string imageLayoutProblem(const sensor_msgs::Image& image);

// A CV_8UC3 RGB copy of an rgb8 or bgr8 image message. Throws InputError naming the encoding for
// anything else (mono images get their own message: the tracker needs colour), and for a message
// whose data is not exactly height x step bytes (imageLayoutProblem).
cv::Mat toRgbMat(const sensor_msgs::Image& image);

// tf's transform (the pose of the child frame in the parent frame) and back. toIsometry throws
// InputError for non-finite values or a quaternion whose norm is not 1 (within 1e-3); it
// normalises the quaternion otherwise.
Eigen::Isometry3d toIsometry(const geometry_msgs::Transform& transform);
geometry_msgs::Transform toTransformMsg(const Eigen::Isometry3d& isometry);

// The 26 pose parameters (metres and radians, HandModel::parameterNames() order) as a JointState.
sensor_msgs::JointState toJointStateMsg(const std::vector<std::string>& names, const Pose& pose,
                                        const std_msgs::Header& header);

// The fingertips (thumb..pinky) as poses with the identity orientation.
geometry_msgs::PoseArray toFingertipsMsg(const Fingertips& fingertips,
                                         const std_msgs::Header& header);

}  // namespace sag_hand_tracker
