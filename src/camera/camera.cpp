#include "sag_hand_tracker/camera/camera.h"

#include <Eigen/LU>
#include <cmath>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "sag_hand_tracker/util/input_limits.h"

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

bool Camera::projectDistorted(const Eigen::Vector3d& world_point, Eigen::Vector2d* pixel) const {
  if (!hasDistortion()) return project(world_point, pixel);
  const Eigen::Vector3d p = world_to_camera * world_point;
  if (p.z() <= 1e-9) return false;
  cv::Mat K_cv;
  cv::eigen2cv(K, K_cv);
  const std::vector<cv::Point3d> ray{cv::Point3d(p.x() / p.z(), p.y() / p.z(), 1.0)};
  std::vector<cv::Point2d> out;
  cv::projectPoints(ray, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K_cv, distortion, out);
  *pixel = Eigen::Vector2d(out[0].x, out[0].y);
  return pixel->allFinite();
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

void checkDistortionCount(std::size_t count, const std::string& who) {
  // The counts OpenCV's distortion models take (undistortPoints asserts on any other).
  if (count == 0 || count == 4 || count == 5 || count == 8 || count == 12 || count == 14) return;
  throw InputError(who + ": " + std::to_string(count) +
                   " distortion coefficients; expected 0 (none), 4 or 5 (plumb_bob), 8 "
                   "(rational_polynomial), 12 or 14");
}

std::string cameraNames(const std::vector<Camera>& cameras) {
  std::string names;
  for (const Camera& camera : cameras) names += (names.empty() ? "" : " ") + camera.name;
  return names;
}

std::string rectificationProblem(const Eigen::Matrix3d& R) {
  if (!R.allFinite()) return "is not finite";
  // All zeros: a driver that leaves R unset (a default-constructed CameraInfo). The tracker uses
  // K and D only, so that is accepted as "not given" rather than refusing the camera.
  if (R.isZero(0.0)) return "";
  const double deviation = (R * R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const double det = R.determinant();
  if (deviation <= 1e-3 && std::abs(det - 1.0) <= 1e-3) return "";
  char text[160];
  std::snprintf(text, sizeof(text),
                "is not a rotation (R R^T differs from the identity by up to %.3g, det %.6g)",
                deviation, det);
  return text;
}

void checkPrincipalPointAndSkew(const Camera& camera, const std::string& who) {
  // A principal point far off the image (cx -5000, 1e300) or a skew larger than the focal length
  // (normally 0) is a broken calibration, not a lens: it projects the hand elsewhere.
  const double cx = camera.K(0, 2), cy = camera.K(1, 2), skew = camera.K(0, 1);
  const double w = camera.width, h = camera.height;
  if (!std::isfinite(cx) || !std::isfinite(cy) || cx < -w || cx > 2.0 * w || cy < -h ||
      cy > 2.0 * h) {
    char text[160];
    std::snprintf(text, sizeof(text),
                  ": principal point (cx %.6g, cy %.6g) outside [-%d, %d] x [-%d, %d] for a %dx%d "
                  "image",
                  cx, cy, camera.width, 2 * camera.width, camera.height, 2 * camera.height,
                  camera.width, camera.height);
    throw InputError(who + text);
  }
  if (!std::isfinite(skew) || !(std::abs(skew) <= camera.K(0, 0))) {
    char text[128];
    std::snprintf(text, sizeof(text), ": skew K(0,1) = %.6g exceeds the focal length fx = %.6g",
                  skew, camera.K(0, 0));
    throw InputError(who + text);
  }
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
  if (camera.K(0, 0) > kMaxFocalLengthPixels || camera.K(1, 1) > kMaxFocalLengthPixels ||
      camera.K(0, 0) < kMinFocalLengthPixels || camera.K(1, 1) < kMinFocalLengthPixels) {
    throw InputError(which + ": focal length outside [" + std::to_string(kMinFocalLengthPixels) +
                     ", " + std::to_string(kMaxFocalLengthPixels) +
                     "] pixels (fx=" + std::to_string(camera.K(0, 0)) +
                     ", fy=" + std::to_string(camera.K(1, 1)) + ")");
  }
  checkImageSize(camera.width, camera.height, which);
  checkPrincipalPointAndSkew(camera, which);
  checkDistortionCount(camera.distortion.size(), which);
  for (double coefficient : camera.distortion) {
    if (!std::isfinite(coefficient)) throw InputError(which + ": distortion is not finite");
  }
  const Eigen::Matrix3d R = camera.world_to_camera.linear();
  if (!R.allFinite() || !camera.world_to_camera.translation().allFinite() ||
      (R * R.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-6 || R.determinant() < 0.0) {
    throw InputError(which + ": extrinsics are not a rigid transform");
  }
}

void checkDistortionInvertible(const Camera& camera, const std::string& who) {
  if (!camera.hasDistortion()) return;
  // OpenCV inverts the distortion iteratively. Wild coefficients give NaN (found by fuzzing
  // camera_info), or finite nonsense (1e6). So each pixel of a 5 x 5 grid over the image, corners
  // included, undistorted (iterated to convergence) and distorted again by the same model, must be
  // finite and come back within a pixel; a real lens's calibration does.
  std::vector<cv::Point2d> in, normalised;
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 5; ++j) in.emplace_back(0.25 * i * camera.width, 0.25 * j * camera.height);
  }
  cv::Mat K_cv;
  cv::eigen2cv(camera.K, K_cv);
  cv::undistortPoints(
      in, normalised, K_cv, camera.distortion, cv::noArray(), cv::noArray(),
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12));
  std::vector<cv::Point3d> rays;
  double widest = 0.0;  // the largest undistorted radius over the grid (normalised)
  for (const cv::Point2d& p : normalised) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) {
      throw InputError(who + ": the distortion coefficients cannot be inverted over the image " +
                       "(undistorted pixels are not finite)");
    }
    rays.emplace_back(p.x, p.y, 1.0);
    widest = std::max(widest, std::hypot(p.x, p.y));
  }
  // A lens whose radial mapping turns back inside the image folds it over: several rays meet at
  // one pixel, and the grid's round trip below still passes (k1 0.1, k4 100 sent every pixel 21
  // px from the centre to a ray 87-89.9 deg off the axis). The distorted radius
  // r (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6) must grow with r up to the
  // widest ray the image's pixels undistort to.
  const std::vector<double>& d = camera.distortion;
  auto coefficient = [&d](size_t i) { return i < d.size() ? d[i] : 0.0; };
  const double k1 = coefficient(0), k2 = coefficient(1), k3 = coefficient(4), k4 = coefficient(5),
               k5 = coefficient(6), k6 = coefficient(7);
  auto distortedRadius = [&](double r) {
    const double r2 = r * r;
    return r * (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1.0 + r2 * (k4 + r2 * (k5 + r2 * k6)));
  };
  constexpr int kSteps = 1000;
  double previous = 0.0;
  for (int step = 1; step <= kSteps; ++step) {
    const double r = std::tan(std::atan(widest) * step / kSteps);  // even steps of the ray's angle
    const double distorted = distortedRadius(r);
    if (!(distorted > previous)) {
      char where[160];
      std::snprintf(where, sizeof(where),
                    "the lens folds the image over: its radial mapping stops growing %.1f deg off "
                    "the axis, inside the image's widest ray at %.1f deg",
                    std::atan(r) * 180.0 / M_PI, std::atan(widest) * 180.0 / M_PI);
      throw InputError(who + ": the distortion coefficients cannot be inverted over the image (" +
                       where + ")");
    }
    previous = distorted;
  }
  std::vector<cv::Point2d> back;
  cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K_cv, camera.distortion, back);
  for (size_t k = 0; k < in.size(); ++k) {
    const double error = std::hypot(back[k].x - in[k].x, back[k].y - in[k].y);
    if (!(error <= 1.0)) {
      char where[96];
      std::snprintf(where, sizeof(where), "pixel (%.0f, %.0f) comes back %.3g pixels off", in[k].x,
                    in[k].y, error);
      throw InputError(who + ": the distortion coefficients cannot be inverted over the image (" +
                       where + " after undistorting and distorting again)");
    }
  }
}

namespace {

// The Gaussians whose undistorted means `out` (from `first` on) are finite, moved there; a Gaussian
// the distortion cannot place is dropped rather than passed on as NaN.
std::vector<ImageGaussian> placedGaussians(const std::vector<ImageGaussian>& gaussians,
                                           const std::vector<cv::Point2d>& out, size_t first) {
  std::vector<ImageGaussian> placed;
  placed.reserve(gaussians.size());
  for (size_t i = 0; i < gaussians.size(); ++i) {
    const cv::Point2d& p = out[first + i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) continue;
    placed.push_back(gaussians[i]);
    placed.back().mean = Eigen::Vector2d(p.x, p.y);
  }
  return placed;
}

}  // namespace

void undistortImageSoG(const Camera& camera, ImageSoG* sog) {
  if (!camera.hasDistortion() || (sog->gaussians.empty() && sog->arm_cells == 0)) return;
  cv::Mat K_cv;
  cv::eigen2cv(camera.K, K_cv);
  std::vector<cv::Point2d> in, out;
  in.reserve(sog->gaussians.size() + sog->arm_gaussians.size() + 1);
  for (const ImageGaussian& g : sog->gaussians) in.emplace_back(g.mean.x(), g.mean.y());
  for (const ImageGaussian& g : sog->arm_gaussians) in.emplace_back(g.mean.x(), g.mean.y());
  in.emplace_back(sog->arm_centroid.x(), sog->arm_centroid.y());
  cv::undistortPoints(in, out, K_cv, camera.distortion, cv::noArray(), K_cv);
  const size_t count = sog->gaussians.size();
  sog->gaussians = placedGaussians(sog->gaussians, out, 0);
  sog->arm_gaussians = placedGaussians(sog->arm_gaussians, out, count);
  if (sog->arm_cells > 0) {
    const cv::Point2d& arm = out.back();
    if (std::isfinite(arm.x) && std::isfinite(arm.y)) {
      sog->arm_centroid = Eigen::Vector2d(arm.x, arm.y);
    } else {
      sog->arm_cells = 0;  // the sleeve's centroid cannot be placed: no forearm cue
      sog->arm_gaussians.clear();
    }
  }
}

Ray pixelRay(const Camera& camera, const Eigen::Vector2d& undistorted_pixel) {
  const Eigen::Vector3d local =
      camera.K.inverse() * Eigen::Vector3d(undistorted_pixel.x(), undistorted_pixel.y(), 1.0);
  return Ray{camera.centre(), (camera.world_to_camera.linear().transpose() * local).normalized()};
}

bool triangulate(const std::vector<Ray>& rays, Eigen::Vector3d* point) {
  if (rays.size() < 2) return false;
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const Ray& ray : rays) {
    const Eigen::Matrix3d projector =
        Eigen::Matrix3d::Identity() - ray.direction * ray.direction.transpose();
    A += projector;
    b += projector * ray.origin;
  }
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(A);
  if (lu.rank() < 3) return false;
  *point = lu.solve(b);
  return point->allFinite();
}

bool isInFrontOfCameras(const Eigen::Vector3d& point, const std::vector<Camera>& cameras,
                        double min_depth) {
  for (const Camera& camera : cameras) {
    if (!((camera.world_to_camera * point).z() >= min_depth)) return false;
  }
  return true;
}

}  // namespace sag_hand_tracker
