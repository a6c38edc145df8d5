// Overlap D_pq of two 2D Gaussians (paper eq. 7) and its derivatives.
#pragma once

#include <Eigen/Core>
#include <cmath>

#include "sag_hand_tracker/types.h"

namespace sag_hand_tracker {

// D_pq = 2 pi sqrt(|Sp||Sq|) / sqrt(|Sp + Sq|) exp(-1/2 d^T (Sp + Sq)^-1 d), d = mu_p - mu_q:
// the integral over the plane of the product of the two un-normalised Gaussians (eq. 7).
double gaussianOverlap(const Eigen::Vector2d& mean_p, const Eigen::Matrix2d& cov_p,
                       const Eigen::Vector2d& mean_q, const Eigen::Matrix2d& cov_q);

// A projected model Gaussian prepared once per (Gaussian, camera) for the pair loop.
struct OverlapTerm {
  double mean_x, mean_y;
  double cov_xx, cov_xy, cov_yy;
  double sqrt_det;                // sqrt |Sigma_p|
  double inv_xx, inv_xy, inv_yy;  // Sigma_p^-1
};
OverlapTerm prepareOverlapTerm(const ProjectedGaussian& projected);

// Derivatives of D_pq with respect to mean_p and the unique entries (xx, xy, yy) of cov_p.
struct OverlapGradient {
  double d_mean_x, d_mean_y;
  double d_cov_xx, d_cov_xy, d_cov_yy;
};

// Eq. 7 for an isotropic q (the image Gaussians), the hot loop of the energy. Returns 0 when the
// Mahalanobis term exceeds `max_mahalanobis_sq` (the pair contributes < exp(-max/2) of its peak).
// With S = Sigma_p + Sigma_q and u = S^-1 d:
//   dD/dmu_p = -D u,   dD/dSigma_p = D/2 (Sigma_p^-1 - S^-1 + u u^T).
inline double overlapIsotropic(const OverlapTerm& p, double mean_x, double mean_y,
                               double variance_q, double max_mahalanobis_sq,
                               OverlapGradient* gradient) {
  const double s_xx = p.cov_xx + variance_q, s_xy = p.cov_xy, s_yy = p.cov_yy + variance_q;
  const double det_s = s_xx * s_yy - s_xy * s_xy;
  const double inv_det_s = 1.0 / det_s;
  const double dx = p.mean_x - mean_x, dy = p.mean_y - mean_y;
  const double u_x = (s_yy * dx - s_xy * dy) * inv_det_s;
  const double u_y = (s_xx * dy - s_xy * dx) * inv_det_s;
  const double mahalanobis_sq = dx * u_x + dy * u_y;
  if (mahalanobis_sq > max_mahalanobis_sq) return 0.0;
  const double value =
      2.0 * M_PI * p.sqrt_det * variance_q * std::sqrt(inv_det_s) * std::exp(-0.5 * mahalanobis_sq);
  if (gradient) {
    gradient->d_mean_x = -value * u_x;
    gradient->d_mean_y = -value * u_y;
    const double half = 0.5 * value;
    gradient->d_cov_xx = half * (p.inv_xx - s_yy * inv_det_s + u_x * u_x);
    gradient->d_cov_xy = value * (p.inv_xy + s_xy * inv_det_s + u_x * u_y);  // xy and yx together
    gradient->d_cov_yy = half * (p.inv_yy - s_xx * inv_det_s + u_y * u_y);
  }
  return value;
}

}  // namespace sag_hand_tracker
