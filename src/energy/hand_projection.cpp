#include "sag_hand_tracker/energy/hand_projection.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
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

namespace {

// The silhouettes' ellipses are grown by this much: cv::ellipse, which drew them before
// fillEllipse, adds its polygon's 8-connected outline, about 0.4 pixel beyond the ellipse. Grown
// so, the exact ellipse covers the same area on ellipses of 1 to 24 pixels (a third of the
// pixels that differ without it), and the parameters tuned on those silhouettes (the shape fit's
// score, the finger toggles) keep their meaning.
constexpr double kSilhouetteOutlinePixels = 0.4;

}  // namespace

cv::Rect fillEllipse(const cv::RotatedRect& box, cv::Mat* mask) {
  if (mask->type() != CV_8UC1) throw InputError("fillEllipse: the mask is not CV_8UC1");
  const double a = 0.5 * box.size.width, b = 0.5 * box.size.height;
  const double cx = box.center.x, cy = box.center.y;
  if (!(a > 0.0) || !(b > 0.0) || !std::isfinite(a) || !std::isfinite(b) || !std::isfinite(cx) ||
      !std::isfinite(cy) || !std::isfinite(box.angle)) {
    return {};
  }
  const double angle = box.angle * M_PI / 180.0;
  const double c = std::cos(angle), s = std::sin(angle);
  // Inside: (u / a)^2 + (v / b)^2 <= 1 with u = c dx + s dy and v = -s dx + c dy, that is
  // A dx^2 + 2 B dx dy + C dy^2 <= 1; per row a quadratic in dx.
  const double inv_a2 = 1.0 / (a * a), inv_b2 = 1.0 / (b * b);
  const double A = c * c * inv_a2 + s * s * inv_b2;
  const double B = c * s * (inv_a2 - inv_b2);
  const double C = s * s * inv_a2 + c * c * inv_b2;
  const double half_height = std::sqrt(a * a * s * s + b * b * c * c);
  // Clamped to the image in double first: an ellipse far outside must not overflow an int.
  const double top = std::max(0.0, std::ceil(cy - half_height));
  const double bottom = std::min(mask->rows - 1.0, std::floor(cy + half_height));
  if (!(top <= bottom)) return {};
  const int y0 = static_cast<int>(top), y1 = static_cast<int>(bottom);
  int x_min = mask->cols, x_max = -1, y_min = mask->rows, y_max = -1;
  for (int y = y0; y <= y1; ++y) {
    const double dy = y - cy;
    const double discriminant = B * B * dy * dy - A * (C * dy * dy - 1.0);
    if (!(discriminant >= 0.0)) continue;
    const double half_width = std::sqrt(discriminant) / A;
    const double middle = cx - B * dy / A;
    const double left = std::max(0.0, std::ceil(middle - half_width));
    const double right = std::min(mask->cols - 1.0, std::floor(middle + half_width));
    if (!(left <= right)) continue;
    const int xl = static_cast<int>(left), xr = static_cast<int>(right);
    std::memset(mask->ptr<std::uint8_t>(y) + xl, 255, static_cast<std::size_t>(xr - xl + 1));
    x_min = std::min(x_min, xl);
    x_max = std::max(x_max, xr);
    y_min = std::min(y_min, y);
    y_max = y;
  }
  if (x_max < 0) return {};
  return cv::Rect(x_min, y_min, x_max - x_min + 1, y_max - y_min + 1);
}

cv::Rect drawModelSilhouette(const PosedHand& hand, const Camera& camera, double sigmas,
                             int margin_pixels, cv::Mat* mask) {
  cv::Rect drawn;
  if (!handInFrontOf(hand, camera)) return drawn;
  for (const CameraGaussian& g : projectHand(hand, camera)) {
    cv::RotatedRect box;
    if (!ellipseBox(g.projected, sigmas, margin_pixels + kSilhouetteOutlinePixels, &box)) continue;
    // Far outside the image (a Gaussian seen almost edge-on): nothing to draw.
    if (std::fabs(box.center.x) > 4.0f * camera.width ||
        std::fabs(box.center.y) > 4.0f * camera.height) {
      continue;
    }
    const cv::Rect filled = fillEllipse(box, mask);
    if (!filled.empty()) drawn = drawn.empty() ? filled : (drawn | filled);
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
