// Projection of a 3D Gaussian (camera frame) to a 2D Gaussian in pixels (paper section 4.2).
#pragma once

#include <Eigen/Core>

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

// Derivatives of the projected Gaussian's (mean_x, mean_y, cov_xx, cov_xy, cov_yy) with respect to
// the camera-frame mean (x, y, z) and the covariance's unique entries (xx, yy, zz, xy, xz, yz),
// each off-diagonal entry counted once (it stands for both of its symmetric places).
using ProjectionJacobian = Eigen::Matrix<double, 5, 9>;

// Exact perspective projection of the 1-sigma ellipsoid (paper eqs. 3-5): the silhouette ellipse,
// i.e. the image-plane section of the tangent cone from the camera centre. `mean`, `cov` in the
// camera optical frame, K the intrinsics. Returns an invalid result (never NaN) when the ellipsoid
// reaches behind the plane 1 cm in front of the camera (so also when the camera is inside it), when
// the covariance is not positive definite, or when the ellipse comes out degenerate. With
// `jacobian`, also its exact derivatives (written only for a valid result).
ProjectedGaussian projectPerspective(const Eigen::Vector3d& mean, const Eigen::Matrix3d& cov,
                                     const Eigen::Matrix3d& K,
                                     ProjectionJacobian* jacobian = nullptr);

// Scaled orthographic projection of an isotropic Gaussian (the SoG baseline, Sridhar et al. 2013):
// the mean projects through the pinhole, sigma scales with f / z.
ProjectedGaussian projectScaledOrthographic(const Eigen::Vector3d& mean, const Eigen::Matrix3d& cov,
                                            const Eigen::Matrix3d& K,
                                            ProjectionJacobian* jacobian = nullptr);

}  // namespace sag_hand_tracker
