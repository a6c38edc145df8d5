// Projection of a 3D Gaussian (camera frame) to a 2D Gaussian in pixels (paper section 4.2).
#pragma once

#include <Eigen/Core>

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

// Exact perspective projection of the 1-sigma ellipsoid (paper eqs. 3-5): the silhouette ellipse,
// i.e. the image-plane section of the tangent cone from the camera centre. `mean`, `cov` in the
// camera optical frame, K the intrinsics. Returns an invalid result (never NaN) when the camera is
// inside the ellipsoid, when the ellipsoid reaches behind the image plane, or when the cone matrix
// is near-singular.
ProjectedGaussian projectPerspective(const Eigen::Vector3d& mean, const Eigen::Matrix3d& cov,
                                     const Eigen::Matrix3d& K);

// Scaled orthographic projection of an isotropic Gaussian (the SoG baseline, Sridhar et al. 2013):
// the mean projects through the pinhole, sigma scales with f / z.
ProjectedGaussian projectScaledOrthographic(const Eigen::Vector3d& mean, const Eigen::Matrix3d& cov,
                                            const Eigen::Matrix3d& K);

}  // namespace sag_hand_tracker
