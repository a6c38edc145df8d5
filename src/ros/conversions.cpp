#include "sag_hand_tracker/ros/conversions.h"

#include <image_geometry/pinhole_camera_model.h>
#include <sensor_msgs/distortion_models.h>
#include <sensor_msgs/image_encodings.h>

#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/util/input_limits.h"
#include "sag_hand_tracker/util/number_text.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

const std::string kOpticalSuffix = "_optical_frame";

}  // namespace

std::string cameraNameFromFrame(const std::string& frame_id) {
  std::string name = frame_id;
  if (!name.empty() && name.front() == '/') name.erase(0, 1);
  if (name.size() > kOpticalSuffix.size() &&
      name.compare(name.size() - kOpticalSuffix.size(), kOpticalSuffix.size(), kOpticalSuffix) ==
          0) {
    name.resize(name.size() - kOpticalSuffix.size());
  }
  return name;
}

sensor_msgs::CameraInfo toCameraInfo(const Camera& camera) {
  sensor_msgs::CameraInfo info;
  info.header.frame_id = opticalFrame(camera.name);
  info.width = static_cast<std::uint32_t>(camera.width);
  info.height = static_cast<std::uint32_t>(camera.height);
  if (camera.distortion.size() > 5) {
    info.distortion_model = sensor_msgs::distortion_models::RATIONAL_POLYNOMIAL;
    info.D = camera.distortion;
    info.D.resize(8, 0.0);
  } else {
    info.distortion_model = sensor_msgs::distortion_models::PLUMB_BOB;
    info.D = camera.distortion;
    info.D.resize(5, 0.0);
  }
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      info.K[3 * r + c] = camera.K(r, c);
      info.R[3 * r + c] = r == c ? 1.0 : 0.0;
      info.P[4 * r + c] = camera.K(r, c);
    }
  }
  return info;
}

Camera fromCameraInfo(const sensor_msgs::CameraInfo& info, const std::string& camera_name) {
  Camera camera;
  camera.name = camera_name.empty() ? cameraNameFromFrame(info.header.frame_id) : camera_name;
  const std::string who = "camera '" + camera.name + "': camera_info ";
  if (info.width == 0 || info.height == 0) {
    throw InputError(who + "has a zero image size (" + std::to_string(info.width) + "x" +
                     std::to_string(info.height) + ")");
  }
  checkImageSize(info.width, info.height, who.substr(0, who.size() - 1));
  if (info.binning_x > 1 || info.binning_y > 1) {
    throw InputError(who + "uses binning, which is not supported");
  }
  const sensor_msgs::RegionOfInterest& roi = info.roi;
  const bool full_roi =
      (roi.width == 0 && roi.height == 0) || (roi.x_offset == 0 && roi.y_offset == 0 &&
                                              roi.width == info.width && roi.height == info.height);
  if (!full_roi) throw InputError(who + "has a region of interest, which is not supported");
  const std::string& model = info.distortion_model;
  const bool no_distortion = model.empty() && info.D.empty();
  if (!no_distortion && model != sensor_msgs::distortion_models::PLUMB_BOB &&
      model != sensor_msgs::distortion_models::RATIONAL_POLYNOMIAL) {
    throw InputError(who + "has the unsupported distortion model '" + model +
                     "' (plumb_bob or rational_polynomial)");
  }
  for (double value : info.K) {
    if (!std::isfinite(value)) throw InputError(who + "has a non-finite camera matrix K");
  }
  for (double value : info.D) {
    if (!std::isfinite(value)) throw InputError(who + "has non-finite distortion coefficients");
  }
  // R and P are not used (the tracker works on raw images with K and D), but NaN in them or an R
  // that is neither a rotation nor unset (all zeros) is a broken calibration, refused like a
  // broken K.
  for (double value : info.P) {
    if (!std::isfinite(value)) throw InputError(who + "has a non-finite projection matrix P");
  }
  for (double value : info.R) {
    if (!std::isfinite(value)) throw InputError(who + "has a non-finite rectification matrix R");
  }
  const std::string rectification = rectificationProblem(
      Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(info.R.data()));
  if (!rectification.empty()) {
    throw InputError(who + "has a rectification matrix R that " + rectification);
  }
  if (!(info.K[0] > 0.0) || !(info.K[4] > 0.0)) {
    throw InputError(who + "has a zero or negative focal length (fx " + shortNumber(info.K[0]) +
                     ", fy " + shortNumber(info.K[4]) + "): is the camera calibrated?");
  }

  if (info.K[0] > kMaxFocalLengthPixels || info.K[4] > kMaxFocalLengthPixels ||
      info.K[0] < kMinFocalLengthPixels || info.K[4] < kMinFocalLengthPixels) {
    throw InputError(who + "has a focal length outside [" + shortNumber(kMinFocalLengthPixels) +
                     ", " + shortNumber(kMaxFocalLengthPixels) + "] pixels (fx " +
                     shortNumber(info.K[0]) + ", fy " + shortNumber(info.K[4]) + ")");
  }
  // image_geometry divides by zero (SIGFPE) on an empty D (with or without a model), and OpenCV
  // asserts on counts it does not know: an empty D is no distortion, 4 or 5 (plumb_bob) are
  // padded with zeros, anything else is refused here with the camera's name. rational_polynomial
  // has 8 (k1 k2 p1 p2 k3 k4 k5 k6): 5 of them were padded, i.e. taken as plumb_bob.
  const bool rational = model == sensor_msgs::distortion_models::RATIONAL_POLYNOMIAL;
  const std::size_t count = info.D.size();
  if (rational && count != 8) {
    throw InputError(who + "has " + std::to_string(count) +
                     " distortion coefficients for rational_polynomial (expected 8: k1 k2 p1 p2 "
                     "k3 k4 k5 k6; 5 are plumb_bob's)");
  }
  if (!rational && !(count == 0 || count == 4 || count == 5)) {
    throw InputError(who + "has " + std::to_string(count) + " distortion coefficients for " +
                     (model.empty() ? std::string("no distortion model") : model) +
                     " (expected 0, 4 or 5)");
  }
  sensor_msgs::CameraInfo padded = info;
  if (padded.distortion_model.empty()) {
    padded.distortion_model = sensor_msgs::distortion_models::PLUMB_BOB;
  }
  padded.D.resize(rational ? 8 : 5, 0.0);

  image_geometry::PinholeCameraModel pinhole;
  try {
    pinhole.fromCameraInfo(padded);
  } catch (const std::exception& error) {
    throw InputError(who + "is not usable: " + error.what());
  }
  const cv::Matx33d& K = pinhole.fullIntrinsicMatrix();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) camera.K(r, c) = K(r, c);
  }
  const cv::Size size = pinhole.fullResolution();
  camera.width = size.width;
  camera.height = size.height;
  const cv::Mat_<double>& D = pinhole.distortionCoeffs();
  camera.distortion.assign(D.begin(), D.end());
  validateCamera(camera);
  checkDistortionInvertible(camera, who.substr(0, who.size() - 1));
  return camera;
}

sensor_msgs::Image toImageMsg(const cv::Mat& rgb, const std_msgs::Header& header) {
  if (rgb.type() != CV_8UC3) {
    throw std::invalid_argument("toImageMsg: expected a CV_8UC3 RGB image");
  }
  sensor_msgs::Image image;
  image.header = header;
  image.height = static_cast<std::uint32_t>(rgb.rows);
  image.width = static_cast<std::uint32_t>(rgb.cols);
  image.encoding = sensor_msgs::image_encodings::RGB8;
  image.is_bigendian = 0;
  image.step = static_cast<std::uint32_t>(rgb.cols * 3);
  image.data.resize(static_cast<std::size_t>(image.step) * image.height);
  for (int row = 0; row < rgb.rows; ++row) {
    std::memcpy(&image.data[static_cast<std::size_t>(row) * image.step], rgb.ptr(row), image.step);
  }
  return image;
}

bool isSupportedEncoding(const std::string& encoding) {
  return encoding == sensor_msgs::image_encodings::RGB8 ||
         encoding == sensor_msgs::image_encodings::BGR8;
}

std::string imageLayoutProblem(const sensor_msgs::Image& image) {
  const std::size_t row_bytes = static_cast<std::size_t>(image.width) * 3;
  const std::size_t expected = static_cast<std::size_t>(image.step) * image.height;
  // Fewer bytes would be read past the end; more were silently ignored (a wrong height or step,
  // two images in one message): either way the message does not describe its data.
  if (image.step >= row_bytes && image.data.size() == expected) return "";
  const std::string problem = "malformed image: " + std::to_string(image.data.size()) +
                              " bytes for " + std::to_string(image.width) + "x" +
                              std::to_string(image.height) + " with step " +
                              std::to_string(image.step);
  if (image.step < row_bytes) {
    return problem + ", less than width x 3 = " + std::to_string(row_bytes);
  }
  return problem + ", not step x height = " + std::to_string(expected);
}

cv::Mat toRgbMat(const sensor_msgs::Image& image) {
  namespace enc = sensor_msgs::image_encodings;
  if (!isSupportedEncoding(image.encoding)) {
    if (enc::isMono(image.encoding)) {
      throw InputError("mono image (encoding '" + image.encoding +
                       "'): the tracker needs colour images, rgb8 or bgr8");
    }
    throw InputError("unsupported image encoding '" + image.encoding + "' (expected rgb8 or bgr8)");
  }
  if (image.width == 0 || image.height == 0) throw InputError("empty image (0 pixels)");
  checkImageSize(image.width, image.height, "image");
  const std::string layout = imageLayoutProblem(image);
  if (!layout.empty()) throw InputError(layout);
  // Wraps the message's bytes without copying, then copies (and reorders) into the result.
  const cv::Mat wrapped(static_cast<int>(image.height), static_cast<int>(image.width), CV_8UC3,
                        const_cast<std::uint8_t*>(image.data.data()), image.step);
  cv::Mat rgb;
  if (image.encoding == enc::BGR8) {
    cv::cvtColor(wrapped, rgb, cv::COLOR_BGR2RGB);
  } else {
    rgb = wrapped.clone();
  }
  return rgb;
}

Eigen::Isometry3d toIsometry(const geometry_msgs::Transform& transform) {
  const auto& t = transform.translation;
  const auto& r = transform.rotation;
  for (double value : {t.x, t.y, t.z, r.x, r.y, r.z, r.w}) {
    if (!std::isfinite(value)) throw InputError("transform has non-finite values");
  }
  const Eigen::Quaterniond q(r.w, r.x, r.y, r.z);
  if (std::abs(q.norm() - 1.0) > 1e-3) {
    throw InputError("transform rotation is not a unit quaternion (norm " + shortNumber(q.norm()) +
                     ")");
  }
  Eigen::Isometry3d isometry = Eigen::Isometry3d::Identity();
  isometry.linear() = q.normalized().toRotationMatrix();
  isometry.translation() = Eigen::Vector3d(t.x, t.y, t.z);
  return isometry;
}

geometry_msgs::Transform toTransformMsg(const Eigen::Isometry3d& isometry) {
  geometry_msgs::Transform transform;
  const Eigen::Vector3d t = isometry.translation();
  transform.translation.x = t.x();
  transform.translation.y = t.y();
  transform.translation.z = t.z();
  Eigen::Quaterniond q(isometry.rotation());
  q.normalize();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  transform.rotation.x = q.x();
  transform.rotation.y = q.y();
  transform.rotation.z = q.z();
  transform.rotation.w = q.w();
  return transform;
}

sensor_msgs::JointState toJointStateMsg(const std::vector<std::string>& names, const Pose& pose,
                                        const std_msgs::Header& header) {
  sensor_msgs::JointState message;
  message.header = header;
  message.name = names;
  const PoseVector parameters = pose.toVector();
  message.position.assign(parameters.data(), parameters.data() + parameters.size());
  return message;
}

geometry_msgs::PoseArray toFingertipsMsg(const Fingertips& fingertips,
                                         const std_msgs::Header& header) {
  geometry_msgs::PoseArray message;
  message.header = header;
  for (const Eigen::Vector3d& tip : fingertips) {
    geometry_msgs::Pose pose;
    pose.position.x = tip.x();
    pose.position.y = tip.y();
    pose.position.z = tip.z();
    pose.orientation.w = 1.0;
    message.poses.push_back(pose);
  }
  return message;
}

}  // namespace sag_hand_tracker
