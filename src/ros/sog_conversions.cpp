#include "sag_hand_tracker/ros/sog_conversions.h"

#include <cmath>
#include <string>

namespace sag_hand_tracker {

ImageSoG sogFromMsg(const sag_hand_tracker::SumOfGaussians& msg) {
  if (msg.width > static_cast<uint32_t>(kMaxImageSide) ||
      msg.height > static_cast<uint32_t>(kMaxImageSide)) {
    throw InputError("image SoG size " + std::to_string(msg.width) + "x" +
                     std::to_string(msg.height) + " exceeds the limit of " +
                     std::to_string(kMaxImageSide) + " pixels a side");
  }
  if (msg.gaussians.size() > static_cast<size_t>(kMaxImageGaussians)) {
    throw InputError("image SoG has " + std::to_string(msg.gaussians.size()) +
                     " Gaussians, more than the limit of " + std::to_string(kMaxImageGaussians));
  }
  ImageSoG sog;
  sog.width = static_cast<int>(msg.width);
  sog.height = static_cast<int>(msg.height);
  sog.gaussians.reserve(msg.gaussians.size());
  for (size_t i = 0; i < msg.gaussians.size(); ++i) {
    const auto& g = msg.gaussians[i];
    if (!std::isfinite(g.x) || !std::isfinite(g.y) || !std::isfinite(g.sigma) || !(g.sigma > 0) ||
        !std::isfinite(g.h) || !std::isfinite(g.s) || !std::isfinite(g.v)) {
      throw InputError("image Gaussian " + std::to_string(i) + " is not finite or has sigma <= 0");
    }
    sog.gaussians.push_back({Eigen::Vector2d(g.x, g.y), g.sigma, Hsv(g.h, g.s, g.v)});
  }
  if (msg.arm_cells > 0) {
    if (!std::isfinite(msg.arm_x) || !std::isfinite(msg.arm_y) ||
        msg.arm_cells > static_cast<uint32_t>(kMaxImageSide) * kMaxImageSide) {
      throw InputError("image SoG's forearm evidence (arm_cells " + std::to_string(msg.arm_cells) +
                       ") has a centroid that is not finite or too many cells");
    }
    sog.arm_cells = static_cast<int>(msg.arm_cells);
    sog.arm_centroid = Eigen::Vector2d(msg.arm_x, msg.arm_y);
  }
  return sog;
}

sag_hand_tracker::SumOfGaussians sogToMsg(const ImageSoG& sog) {
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
  if (sog.arm_cells > 0) {
    msg.arm_cells = static_cast<uint32_t>(sog.arm_cells);
    msg.arm_x = static_cast<float>(sog.arm_centroid.x());
    msg.arm_y = static_cast<float>(sog.arm_centroid.y());
  }
  return msg;
}

}  // namespace sag_hand_tracker
