// A calibrated pinhole camera: intrinsics K, distortion, image size and the root->camera pose.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

struct Camera {
  std::string name;  // e.g. "cam0"; its optical frame is "<name>_optical_frame"
  int width = 0;
  int height = 0;
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  // plumb_bob / rational_polynomial coefficients (k1 k2 p1 p2 [k3 ...]); empty or zero = none.
  std::vector<double> distortion;
  // root (world) frame -> camera optical frame (z forward, x right, y down).
  Eigen::Isometry3d world_to_camera = Eigen::Isometry3d::Identity();

  bool hasDistortion() const;
  Eigen::Vector3d centre() const;  // camera centre in the root frame
  // Pinhole projection of a root-frame point to pixels (no distortion); false if behind.
  bool project(const Eigen::Vector3d& world_point, Eigen::Vector2d* pixel) const;
  // Maps a distorted pixel to the ideal pinhole pixel (identity without distortion).
  Eigen::Vector2d undistortPixel(const Eigen::Vector2d& pixel) const;
  // Pinhole projection followed by the distortion: where the point lies in the image as the camera
  // delivers it (project() without distortion); false if behind.
  bool projectDistorted(const Eigen::Vector3d& world_point, Eigen::Vector2d* pixel) const;
};

// Throws InputError naming the camera and the problem (zero, negative or huge focal length,
// non-finite values, bad or too large image size, a distortion count OpenCV does not take,
// extrinsics not a rigid transform). The limits are in input_limits.h.
void validateCamera(const Camera& camera);

// The cameras' names separated by spaces ("cam0 cam1 cam2"), for messages.
std::string cameraNames(const std::vector<Camera>& cameras);
// Throws InputError "<who>: principal point ..." unless cx, cy are finite and within
// [-width, 2 width] x [-height, 2 height], or "<who>: skew ..." when |K(0,1)| exceeds fx. Part of
// validateCamera; calibration files call it for their camera_matrix too.
void checkPrincipalPointAndSkew(const Camera& camera, const std::string& who);
// Throws InputError "<who>: N distortion coefficients; expected ..." unless `count` is one OpenCV
// takes (0, 4, 5, 8, 12, 14).
void checkDistortionCount(std::size_t count, const std::string& who);

// What is wrong with a rectification matrix R (camera_info's R, a calibration file's
// rectification_matrix), or "" when it is a rotation: finite, R R^T within 1e-3 of the identity
// and det R within 1e-3 of 1, or all zeros (R left unset by a driver). E.g. "is not a rotation
// (R R^T differs from the identity by up to 3, det 8)". The tracker does not rectify, but a scaled
// or mirrored R is a broken calibration.
std::string rectificationProblem(const Eigen::Matrix3d& R);

// Throws InputError "<who>: the distortion coefficients cannot be inverted ..." when undistorting
// a grid over the image gives non-finite pixels, or pixels that the same model does not distort
// back to within a pixel of where they were (wild coefficients). Checked where cameras enter
// (calibration files, camera_info), not per frame.
void checkDistortionInvertible(const Camera& camera, const std::string& who);

// A ray in the root frame: from a camera centre through a pixel.
struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;  // unit
};

// The ray through an undistorted (ideal pinhole) pixel.
Ray pixelRay(const Camera& camera, const Eigen::Vector2d& undistorted_pixel);

// Least-squares point closest to all rays; false for fewer than 2 rays or parallel ones.
bool triangulate(const std::vector<Ray>& rays, Eigen::Vector3d* point);

// Whether a root-frame point lies at least min_depth (metres) in front of every camera (along its
// optical axis). A hand hypothesis behind a camera that sees the hand is no hypothesis.
bool isInFrontOfCameras(const Eigen::Vector3d& point, const std::vector<Camera>& cameras,
                        double min_depth = 0.05);

// Moves every image Gaussian of `sog` to ideal pinhole coordinates (no-op without distortion);
// one the distortion cannot place (non-finite) is dropped.
void undistortImageSoG(const Camera& camera, ImageSoG* sog);

}  // namespace sag_hand_tracker
