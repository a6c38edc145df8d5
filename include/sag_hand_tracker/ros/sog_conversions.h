// Message <-> core conversions for the image SoG and camera messages, and HSV -> RGB for display
// (ROS layer, header-only; used by the nodelets and the graph tests).
#pragma once

#include <geometry_msgs/Transform.h>
#include <sensor_msgs/CameraInfo.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>

#include "sag_hand_tracker/SumOfGaussians.h"
#include "sag_hand_tracker/camera.h"
#include "sag_hand_tracker/types.h"

namespace sag_hand_tracker {
namespace ros_util {

// Intrinsics and size from a CameraInfo; world_to_camera from the given tf transform
// root -> optical frame (which maps optical-frame points into the root frame).
inline Camera cameraFromInfo(const sensor_msgs::CameraInfo& info, const std::string& name,
                             const geometry_msgs::Transform& root_to_optical) {
  Camera camera;
  camera.name = name;
  camera.width = static_cast<int>(info.width);
  camera.height = static_cast<int>(info.height);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) camera.K(r, c) = info.K[r * 3 + c];
  camera.distortion.assign(info.D.begin(), info.D.end());
  Eigen::Isometry3d camera_to_world = Eigen::Isometry3d::Identity();
  const auto& q = root_to_optical.rotation;
  camera_to_world.linear() = Eigen::Quaterniond(q.w, q.x, q.y, q.z).normalized().toRotationMatrix();
  const auto& t = root_to_optical.translation;
  camera_to_world.translation() = Eigen::Vector3d(t.x, t.y, t.z);
  camera.world_to_camera = camera_to_world.inverse();
  return camera;
}

// Core image SoG from the message (raw pixels). Throws InputError naming the first non-finite or
// negative value.
inline ImageSoG sogFromMsg(const sag_hand_tracker::SumOfGaussians& msg) {
  ImageSoG sog;
  sog.width = static_cast<int>(msg.width);
  sog.height = static_cast<int>(msg.height);
  sog.gaussians.reserve(msg.gaussians.size());
  for (size_t i = 0; i < msg.gaussians.size(); ++i) {
    const auto& g = msg.gaussians[i];
    if (!std::isfinite(g.x) || !std::isfinite(g.y) || !std::isfinite(g.sigma) || !(g.sigma > 0) ||
        !std::isfinite(g.h) || !std::isfinite(g.s) || !std::isfinite(g.v)) {
      throw InputError("image Gaussian " + std::to_string(i) +
                       " is not finite or has sigma <= 0");
    }
    sog.gaussians.push_back({Eigen::Vector2d(g.x, g.y), g.sigma, Hsv(g.h, g.s, g.v)});
  }
  return sog;
}

inline sag_hand_tracker::SumOfGaussians sogToMsg(const ImageSoG& sog) {
  sag_hand_tracker::SumOfGaussians msg;
  msg.width = static_cast<uint32_t>(sog.width);
  msg.height = static_cast<uint32_t>(sog.height);
  msg.gaussians.resize(sog.gaussians.size());
  for (size_t i = 0; i < sog.gaussians.size(); ++i) {
    const ImageGaussian& g = sog.gaussians[i];
    auto& m = msg.gaussians[i];
    m.x = static_cast<float>(g.mean.x());
    m.y = static_cast<float>(g.mean.y());
    m.sigma = static_cast<float>(g.sigma);
    m.h = static_cast<float>(g.hsv[0]);
    m.s = static_cast<float>(g.hsv[1]);
    m.v = static_cast<float>(g.hsv[2]);
  }
  return msg;
}

// HSV (h degrees, s and v in [0, 1]) to RGB in [0, 1].
inline Eigen::Vector3d hsvToRgb(const Hsv& hsv) {
  const double h = std::fmod(std::fmod(hsv[0], 360.0) + 360.0, 360.0) / 60.0;
  const double s = std::clamp(hsv[1], 0.0, 1.0), v = std::clamp(hsv[2], 0.0, 1.0);
  const double c = v * s, x = c * (1.0 - std::fabs(std::fmod(h, 2.0) - 1.0)), m = v - c;
  Eigen::Vector3d rgb;
  switch (static_cast<int>(h)) {
    case 0: rgb << c, x, 0; break;
    case 1: rgb << x, c, 0; break;
    case 2: rgb << 0, c, x; break;
    case 3: rgb << 0, x, c; break;
    case 4: rgb << x, 0, c; break;
    default: rgb << c, 0, x; break;
  }
  return rgb + Eigen::Vector3d::Constant(m);
}

}  // namespace ros_util
}  // namespace sag_hand_tracker
