// Test helpers: camera images of the hand model (its Gaussians drawn as skin-coloured 1-sigma
// ellipses, nearest in front) over a textured desk, for tests of the whole pipeline from pixels.
// Not a renderer for evaluation (that is the studio's, with a hand surface that is not the model).
#pragma once

#include <opencv2/core.hpp>
#include <random>
#include <vector>

#include "sag_hand_tracker/energy/projection.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "test_support/synthetic_scene.h"

namespace sag_test {

using namespace sag_hand_tracker;

// Four 320x240 cameras (f = 300 px) around the workspace centre (0, 0, 0.15).
inline std::vector<Camera> renderedRig() {
  const Eigen::Vector3d centre(0.0, 0.0, 0.15);
  std::vector<Camera> cameras;
  const double azimuths[4] = {0.0, 90.0, 180.0, 270.0};
  const double heights[4] = {0.55, 0.40, 0.60, 0.45};
  for (int i = 0; i < 4; ++i) {
    const double a = azimuths[i] * M_PI / 180.0;
    const Eigen::Vector3d eye =
        centre + Eigen::Vector3d(0.55 * std::cos(a), 0.55 * std::sin(a), heights[i]);
    cameras.push_back(lookAtCamera("cam" + std::to_string(i), eye, centre, 320, 240, 300.0));
  }
  return cameras;
}

// A desk: grey-blue checkerboard with fixed per-pixel noise (the same in every frame).
inline cv::Mat desk(const Camera& camera) {
  cv::Mat rgb(camera.height, camera.width, CV_8UC3);
  std::mt19937 random(static_cast<unsigned>(camera.width + camera.name.back()));
  std::uniform_int_distribution<int> noise(-3, 3);
  for (int y = 0; y < rgb.rows; ++y) {
    for (int x = 0; x < rgb.cols; ++x) {
      const bool dark = ((x / 20) + (y / 20)) % 2 == 0;
      const int base = dark ? 90 : 130;
      rgb.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<uchar>(base - 10 + noise(random)),
                                          cv::saturate_cast<uchar>(base + noise(random)),
                                          cv::saturate_cast<uchar>(base + 25 + noise(random)));
    }
  }
  return rgb;
}

// The desk with the model's Gaussians drawn as filled 1-sigma ellipses in skin colour.
inline cv::Mat renderHand(const HandModel& model, const Pose& pose, const Camera& camera) {
  cv::Mat rgb = desk(camera);
  const PosedHand hand = forwardKinematics(model, pose);
  const Eigen::Matrix3d R = camera.world_to_camera.linear();
  std::vector<std::pair<double, ProjectedGaussian>> projected;
  for (const WorldGaussian& g : hand.gaussians) {
    const Eigen::Vector3d mean = camera.world_to_camera * g.mean;
    projected.push_back({mean.z(), projectPerspective(mean, R * g.cov * R.transpose(), camera.K)});
  }
  for (int y = 0; y < rgb.rows; ++y) {
    for (int x = 0; x < rgb.cols; ++x) {
      double nearest = std::numeric_limits<double>::infinity();
      for (const auto& [depth, ellipse] : projected) {
        if (!ellipse.valid || depth >= nearest) continue;
        const Eigen::Vector2d d = Eigen::Vector2d(x, y) - ellipse.mean;
        if (d.dot(ellipse.cov.inverse() * d) <= 1.0) nearest = depth;
      }
      if (std::isfinite(nearest)) {
        // A little shading with depth keeps neighbouring fingers apart.
        const double shade = std::clamp(1.0 - 2.0 * (nearest - 0.6), 0.8, 1.1);
        rgb.at<cv::Vec3b>(y, x) =
            cv::Vec3b(cv::saturate_cast<uchar>(204 * shade), cv::saturate_cast<uchar>(143 * shade),
                      cv::saturate_cast<uchar>(112 * shade));
      }
    }
  }
  return rgb;
}

}  // namespace sag_test
