#include "sag_hand_tracker/ros/sog_conversions.h"

#include <algorithm>
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

std::vector<sag_hand_tracker::ImageCandidate> candidatesToMsg(
    const std::vector<HandCandidate>& candidates) {
  std::vector<sag_hand_tracker::ImageCandidate> msgs(candidates.size());
  for (size_t i = 0; i < candidates.size(); ++i) {
    const HandCandidate& c = candidates[i];
    sag_hand_tracker::ImageCandidate& m = msgs[i];
    m.score = static_cast<float>(c.score);
    m.centroid_x = static_cast<float>(c.centroid.x());
    m.centroid_y = static_cast<float>(c.centroid.y());
    m.box_x = c.box.x;
    m.box_y = c.box.y;
    m.box_width = c.box.width;
    m.box_height = c.box.height;
    m.moving = c.moving;
    m.cell_size = static_cast<uint32_t>(std::max(c.cell_size, 0));
    m.cells_x = static_cast<uint32_t>(std::max(c.cells_x, 0));
    m.cell_indices.assign(c.cell_indices.begin(), c.cell_indices.end());
    m.moving_cell_indices.assign(c.moving_cell_indices.begin(), c.moving_cell_indices.end());
  }
  return msgs;
}

std::vector<HandCandidate> candidatesFromMsg(const sag_hand_tracker::SumOfGaussians& msg) {
  if (msg.candidates.size() > static_cast<size_t>(kMaxHandCandidates)) {
    throw InputError("the SoG carries " + std::to_string(msg.candidates.size()) +
                     " hand candidates, more than the limit of " +
                     std::to_string(kMaxHandCandidates));
  }
  std::vector<HandCandidate> candidates;
  candidates.reserve(msg.candidates.size());
  for (size_t i = 0; i < msg.candidates.size(); ++i) {
    const sag_hand_tracker::ImageCandidate& m = msg.candidates[i];
    const std::string which = "hand candidate " + std::to_string(i);
    if (!std::isfinite(m.score) || !std::isfinite(m.centroid_x) || !std::isfinite(m.centroid_y)) {
      throw InputError(which + ": score or centroid not finite");
    }
    if (m.cell_size < 1 || m.cell_size > msg.width || m.cell_size > msg.height) {
      throw InputError(which + ": cell_size " + std::to_string(m.cell_size) +
                       " does not fit the image");
    }
    const uint32_t cells_x = (msg.width + m.cell_size - 1) / m.cell_size;
    const uint32_t cells_y = (msg.height + m.cell_size - 1) / m.cell_size;
    if (m.cells_x != cells_x) {
      throw InputError(which + ": cells_x " + std::to_string(m.cells_x) + " but a " +
                       std::to_string(msg.width) + " pixel wide image has " +
                       std::to_string(cells_x) + " cells of " + std::to_string(m.cell_size));
    }
    HandCandidate c;
    c.score = m.score;
    c.centroid = Eigen::Vector2d(m.centroid_x, m.centroid_y);
    c.box = cv::Rect(m.box_x, m.box_y, m.box_width, m.box_height);
    c.moving = m.moving;
    c.cell_size = static_cast<int>(m.cell_size);
    c.cells_x = static_cast<int>(m.cells_x);
    auto cellIndices = [&](const std::vector<uint32_t>& indices, const char* what) {
      std::vector<int> cells;
      cells.reserve(indices.size());
      for (const uint32_t index : indices) {
        if (index >= cells_x * cells_y) {
          throw InputError(which + ": " + what + " " + std::to_string(index) + " outside the " +
                           std::to_string(cells_x) + "x" + std::to_string(cells_y) + " cells");
        }
        cells.push_back(static_cast<int>(index));
      }
      return cells;
    };
    c.cell_indices = cellIndices(m.cell_indices, "cell index");
    if (m.moving < 0) {
      throw InputError(which + ": moving " + std::to_string(m.moving) + " is negative");
    }
    // Empty: the moving cells' places are not known, and each counts wherever it is.
    if (!m.moving_cell_indices.empty() &&
        m.moving_cell_indices.size() != static_cast<size_t>(m.moving)) {
      throw InputError(which + ": " + std::to_string(m.moving_cell_indices.size()) +
                       " moving cells listed but moving is " + std::to_string(m.moving));
    }
    c.moving_cell_indices = cellIndices(m.moving_cell_indices, "moving cell index");
    candidates.push_back(std::move(c));
  }
  return candidates;
}

}  // namespace sag_hand_tracker
