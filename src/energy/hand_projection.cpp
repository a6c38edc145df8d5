#include "sag_hand_tracker/energy/hand_projection.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "sag_hand_tracker/energy/projection.h"

namespace sag_hand_tracker {

std::vector<CameraGaussian> projectHand(const PosedHand& hand, const Camera& camera,
                                        ProjectionMode mode) {
  const Eigen::Matrix3d R = camera.world_to_camera.linear();
  std::vector<CameraGaussian> result(hand.gaussians.size());
  for (size_t p = 0; p < hand.gaussians.size(); ++p) {
    const Eigen::Vector3d mean = camera.world_to_camera * hand.gaussians[p].mean;
    const Eigen::Matrix3d cov = R * hand.gaussians[p].cov * R.transpose();
    result[p].depth = mean.z();
    result[p].projected = mode == ProjectionMode::kPerspective
                              ? projectPerspective(mean, cov, camera.K)
                              : projectScaledOrthographic(mean, cov, camera.K);
  }
  return result;
}

std::vector<CameraGaussian> projectModel(const HandModel& model, const PosedHand& hand,
                                         const Camera& camera) {
  return projectHand(hand, camera, model.projection);
}

bool handInFrontOf(const PosedHand& hand, const Camera& camera) {
  for (const WorldGaussian& g : hand.gaussians) {
    if ((camera.world_to_camera * g.mean).z() < 0.02) return false;
  }
  return true;
}

bool ellipseBox(const ProjectedGaussian& g, double sigmas, double margin_pixels,
                cv::RotatedRect* box) {
  if (!g.valid || !g.mean.allFinite() || !g.cov.allFinite()) return false;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(g.cov);
  const Eigen::Vector2d radii = sigmas * eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt() +
                                Eigen::Vector2d::Constant(margin_pixels);
  const Eigen::Vector2d major = eigen.eigenvectors().col(1);
  const double angle = std::atan2(major.y(), major.x()) * 180.0 / M_PI;
  if (!radii.allFinite() || !std::isfinite(angle)) return false;
  *box = cv::RotatedRect(
      cv::Point2f(static_cast<float>(g.mean.x()), static_cast<float>(g.mean.y())),
      cv::Size2f(static_cast<float>(2.0 * radii[1]), static_cast<float>(2.0 * radii[0])),
      static_cast<float>(angle));
  return true;
}

cv::Rect drawModelSilhouette(const PosedHand& hand, const Camera& camera, double sigmas,
                             int margin_pixels, cv::Mat* mask) {
  cv::Rect drawn;
  if (!handInFrontOf(hand, camera)) return drawn;
  const cv::Rect image(0, 0, mask->cols, mask->rows);
  for (const CameraGaussian& g : projectHand(hand, camera)) {
    cv::RotatedRect box;
    if (!ellipseBox(g.projected, sigmas, margin_pixels, &box)) continue;
    // Far outside the image (a Gaussian seen almost edge-on): nothing to draw.
    if (std::fabs(box.center.x) > 4.0f * camera.width ||
        std::fabs(box.center.y) > 4.0f * camera.height) {
      continue;
    }
    cv::ellipse(*mask, box, cv::Scalar(255), cv::FILLED);
    // Two pixels beyond the box, for the rounding of cv::ellipse's polygon.
    const cv::Rect reach = (box.boundingRect() + cv::Size(4, 4) - cv::Point(2, 2)) & image;
    if (!reach.empty()) drawn = drawn.empty() ? reach : (drawn | reach);
  }
  return drawn;
}

cv::Mat projectedModelSilhouette(const PosedHand& hand, const Camera& camera, double sigmas,
                                 int margin_pixels) {
  cv::Mat mask(camera.height, camera.width, CV_8UC1, cv::Scalar(0));
  drawModelSilhouette(hand, camera, sigmas, margin_pixels, &mask);
  return mask;
}

void drawProjectedEllipses(const std::vector<CameraGaussian>& projected, const cv::Scalar& colour,
                           cv::Mat* image) {
  for (const CameraGaussian& g : projected) {
    cv::RotatedRect box;
    if (!ellipseBox(g.projected, 1.0, 0.0, &box)) continue;
    cv::ellipse(*image, box, colour, 1, cv::LINE_AA);
  }
}

}  // namespace sag_hand_tracker
