// Overlap D_pq of two 2D Gaussians (paper eq. 7) and its derivatives.
#pragma once

#include <Eigen/Core>

namespace sag_hand_tracker {

// D_pq = 2 pi sqrt(|Sp||Sq|) / sqrt(|Sp + Sq|) exp(-1/2 d^T (Sp + Sq)^-1 d), d = mu_p - mu_q:
// the integral over the plane of the product of the two un-normalised Gaussians (eq. 7).
double gaussianOverlap(const Eigen::Vector2d& mean_p, const Eigen::Matrix2d& cov_p,
                       const Eigen::Vector2d& mean_q, const Eigen::Matrix2d& cov_q);

// D_pq and its derivative with respect to mean_p and the unique entries (xx, xy, yy) of cov_p,
// for an isotropic q (the image Gaussians): the hot loop of the energy.
struct OverlapWithGradient {
  double value = 0.0;
  Eigen::Vector2d d_mean = Eigen::Vector2d::Zero();
  Eigen::Vector3d d_cov = Eigen::Vector3d::Zero();  // d/d(cov_xx, cov_xy, cov_yy)
};
OverlapWithGradient gaussianOverlapIsotropic(const Eigen::Vector2d& mean_p,
                                             const Eigen::Matrix2d& cov_p,
                                             const Eigen::Vector2d& mean_q, double sigma_q);

}  // namespace sag_hand_tracker
