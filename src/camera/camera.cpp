#include "sag_hand_tracker/camera/camera.h"

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

namespace sag_hand_tracker {

bool Camera::hasDistortion() const {
  for (double coefficient : distortion) {
    if (coefficient != 0.0) return true;
  }
  return false;
}

Eigen::Vector3d Camera::centre() const { return world_to_camera.inverse().translation(); }

bool Camera::project(const Eigen::Vector3d& world_point, Eigen::Vector2d* pixel) const {
  const Eigen::Vector3d p = world_to_camera * world_point;
  if (p.z() <= 1e-9) return false;
  const Eigen::Vector3d h = K * (p / p.z());
  *pixel = h.head<2>();
  return true;
}

Eigen::Vector2d Camera::undistortPixel(const Eigen::Vector2d& pixel) const {
  if (!hasDistortion()) return pixel;
  cv::Mat K_cv;
  cv::eigen2cv(K, K_cv);
  const std::vector<cv::Point2d> in{cv::Point2d(pixel.x(), pixel.y())};
  std::vector<cv::Point2d> out;
  cv::undistortPoints(in, out, K_cv, distortion, cv::noArray(), K_cv);
  return Eigen::Vector2d(out[0].x, out[0].y);
}

void validateCamera(const Camera& camera) {
  const std::string which = "camera '" + camera.name + "'";
  if (!camera.K.allFinite()) throw InputError(which + ": intrinsics are not finite");
  if (!(camera.K(0, 0) > 0.0) || !(camera.K(1, 1) > 0.0)) {
    throw InputError(which +
                     ": focal length must be positive (fx=" + std::to_string(camera.K(0, 0)) +
                     ", fy=" + std::to_string(camera.K(1, 1)) + ")");
  }
  if (camera.K(1, 0) != 0.0 || camera.K(2, 0) != 0.0 || camera.K(2, 1) != 0.0 ||
      camera.K(2, 2) != 1.0) {
    throw InputError(which + ": K must be upper triangular with K(2,2) = 1");
  }
  if (camera.width <= 0 || camera.height <= 0) {
    throw InputError(which + ": image size " + std::to_string(camera.width) + "x" +
                     std::to_string(camera.height) + " is not positive");
  }
  for (double coefficient : camera.distortion) {
    if (!std::isfinite(coefficient)) throw InputError(which + ": distortion is not finite");
  }
  const Eigen::Matrix3d R = camera.world_to_camera.linear();
  if (!R.allFinite() || !camera.world_to_camera.translation().allFinite() ||
      (R * R.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-6 || R.determinant() < 0.0) {
    throw InputError(which + ": extrinsics are not a rigid transform");
  }
}

void undistortImageSoG(const Camera& camera, ImageSoG* sog) {
  if (!camera.hasDistortion() || (sog->gaussians.empty() && sog->arm_cells == 0)) return;
  cv::Mat K_cv;
  cv::eigen2cv(camera.K, K_cv);
  std::vector<cv::Point2d> in, out;
  in.reserve(sog->gaussians.size() + 1);
  for (const ImageGaussian& g : sog->gaussians) in.emplace_back(g.mean.x(), g.mean.y());
  in.emplace_back(sog->arm_centroid.x(), sog->arm_centroid.y());
  cv::undistortPoints(in, out, K_cv, camera.distortion, cv::noArray(), K_cv);
  for (size_t i = 0; i < sog->gaussians.size(); ++i)
    sog->gaussians[i].mean = Eigen::Vector2d(out[i].x, out[i].y);
  if (sog->arm_cells > 0) sog->arm_centroid = Eigen::Vector2d(out.back().x, out.back().y);
}

}  // namespace sag_hand_tracker
