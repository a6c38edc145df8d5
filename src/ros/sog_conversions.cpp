#include "sag_hand_tracker/ros/sog_conversions.h"

#include <cmath>
#include <string>

namespace sag_hand_tracker {

namespace {

// The message's Gaussians; `what` names them in the error (a non-finite value, sigma <= 0).
std::vector<ImageGaussian> gaussiansFromMsg(const std::vector<sag_hand_tracker::Gaussian2D>& msgs,
                                            const std::string& what) {
  std::vector<ImageGaussian> gaussians;
  gaussians.reserve(msgs.size());
  for (size_t i = 0; i < msgs.size(); ++i) {
    const auto& g = msgs[i];
    if (!std::isfinite(g.x) || !std::isfinite(g.y) || !std::isfinite(g.sigma) || !(g.sigma > 0) ||
        !std::isfinite(g.h) || !std::isfinite(g.s) || !std::isfinite(g.v)) {
      throw InputError(what + std::to_string(i) + " is not finite or has sigma <= 0");
    }
    gaussians.push_back({Eigen::Vector2d(g.x, g.y), g.sigma, Hsv(g.h, g.s, g.v)});
  }
  return gaussians;
}

std::vector<sag_hand_tracker::Gaussian2D> gaussiansToMsg(
    const std::vector<ImageGaussian>& gaussians) {
  std::vector<sag_hand_tracker::Gaussian2D> msgs(gaussians.size());
  for (size_t i = 0; i < gaussians.size(); ++i) {
    const ImageGaussian& g = gaussians[i];
    auto& m = msgs[i];
    m.x = static_cast<float>(g.mean.x());
    m.y = static_cast<float>(g.mean.y());
    m.sigma = static_cast<float>(g.sigma);
    m.h = static_cast<float>(g.hsv[0]);
    m.s = static_cast<float>(g.hsv[1]);
    m.v = static_cast<float>(g.hsv[2]);
  }
  return msgs;
}

}  // namespace

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
  if (msg.arm_gaussians.size() > static_cast<size_t>(kMaxImageGaussians)) {
    throw InputError("image SoG has " + std::to_string(msg.arm_gaussians.size()) +
                     " sleeve Gaussians, more than the limit of " +
                     std::to_string(kMaxImageGaussians));
  }
  if (msg.arm_cells == 0 && !msg.arm_gaussians.empty()) {
    throw InputError("image SoG has " + std::to_string(msg.arm_gaussians.size()) +
                     " sleeve Gaussians but arm_cells 0");
  }
  ImageSoG sog;
  sog.width = static_cast<int>(msg.width);
  sog.height = static_cast<int>(msg.height);
  sog.gaussians = gaussiansFromMsg(msg.gaussians, "image Gaussian ");
  if (msg.arm_cells > 0) {
    if (!std::isfinite(msg.arm_x) || !std::isfinite(msg.arm_y) ||
        msg.arm_cells > static_cast<uint32_t>(kMaxImageSide) * kMaxImageSide) {
      throw InputError("image SoG's forearm evidence (arm_cells " + std::to_string(msg.arm_cells) +
                       ") has a centroid that is not finite or too many cells");
    }
    sog.arm_cells = static_cast<int>(msg.arm_cells);
    sog.arm_centroid = Eigen::Vector2d(msg.arm_x, msg.arm_y);
    sog.arm_gaussians = gaussiansFromMsg(msg.arm_gaussians, "sleeve Gaussian ");
  }
  return sog;
}

sag_hand_tracker::SumOfGaussians sogToMsg(const ImageSoG& sog) {
  sag_hand_tracker::SumOfGaussians msg;
  msg.width = static_cast<uint32_t>(sog.width);
  msg.height = static_cast<uint32_t>(sog.height);
  msg.gaussians = gaussiansToMsg(sog.gaussians);
  if (sog.arm_cells > 0) {
    msg.arm_cells = static_cast<uint32_t>(sog.arm_cells);
    msg.arm_x = static_cast<float>(sog.arm_centroid.x());
    msg.arm_y = static_cast<float>(sog.arm_centroid.y());
    msg.arm_gaussians = gaussiansToMsg(sog.arm_gaussians);
  }
  return msg;
}

}  // namespace sag_hand_tracker
