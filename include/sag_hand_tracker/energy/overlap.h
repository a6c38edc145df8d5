// Overlap D_pq of two 2D Gaussians (paper eq. 7) and its derivatives.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <vector>

#include "sag_hand_tracker/util/types.h"

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

// Eq. 7 for an isotropic q (the image Gaussians), the hot loop of the energy, in three inline
// parts so that the vectorised kernels (overlap_kernels.cpp) can reuse them. With
// S = Sigma_p + sigma_q^2 I, d = mu_p - mu_q and u = S^-1 d:
//   D = 2 pi sqrt(|Sigma_p|) sigma_q^2 / sqrt(|S|) exp(-1/2 d^T u)
//   dD/dmu_p = -D u,   dD/dSigma_p = D/2 (Sigma_p^-1 - S^-1 + u u^T).
struct OverlapGeometry {
  double s_xx, s_xy, s_yy, inv_det_s;
  double u_x, u_y;
  double mahalanobis_sq;
};

inline OverlapGeometry overlapGeometry(const OverlapTerm& p, double mean_x, double mean_y,
                                       double variance_q) {
  OverlapGeometry g;
  g.s_xx = p.cov_xx + variance_q;
  g.s_xy = p.cov_xy;
  g.s_yy = p.cov_yy + variance_q;
  g.inv_det_s = 1.0 / (g.s_xx * g.s_yy - g.s_xy * g.s_xy);
  const double dx = p.mean_x - mean_x, dy = p.mean_y - mean_y;
  g.u_x = (g.s_yy * dx - g.s_xy * dy) * g.inv_det_s;
  g.u_y = (g.s_xx * dy - g.s_xy * dx) * g.inv_det_s;
  g.mahalanobis_sq = dx * g.u_x + dy * g.u_y;
  return g;
}

// D_pq; 0 beyond `max_mahalanobis_sq` (the pair then contributes < exp(-max/2) of its peak).
// Branch-free so that loops over q vectorise.
inline double overlapValue(const OverlapTerm& p, const OverlapGeometry& g, double variance_q,
                           double max_mahalanobis_sq) {
  const double peak = 2.0 * M_PI * p.sqrt_det * variance_q * std::sqrt(g.inv_det_s);
  const bool far = g.mahalanobis_sq > max_mahalanobis_sq;
  const double value = peak * std::exp(-0.5 * (far ? max_mahalanobis_sq : g.mahalanobis_sq));
  return far ? 0.0 : value;
}

inline OverlapGradient overlapGradient(const OverlapTerm& p, const OverlapGeometry& g,
                                       double value) {
  OverlapGradient d;
  d.d_mean_x = -value * g.u_x;
  d.d_mean_y = -value * g.u_y;
  const double half = 0.5 * value;
  d.d_cov_xx = half * (p.inv_xx - g.s_yy * g.inv_det_s + g.u_x * g.u_x);
  d.d_cov_xy = value * (p.inv_xy + g.s_xy * g.inv_det_s + g.u_x * g.u_y);  // xy and yx together
  d.d_cov_yy = half * (p.inv_yy - g.s_xx * g.inv_det_s + g.u_y * g.u_y);
  return d;
}

// All three together, for one pair.
inline double overlapIsotropic(const OverlapTerm& p, double mean_x, double mean_y,
                               double variance_q, double max_mahalanobis_sq,
                               OverlapGradient* gradient) {
  const OverlapGeometry g = overlapGeometry(p, mean_x, mean_y, variance_q);
  const double value = overlapValue(p, g, variance_q, max_mahalanobis_sq);
  if (gradient) *gradient = overlapGradient(p, g, value);
  return value;
}

// Image Gaussians of one camera, structure of arrays for the vectorised kernels, sorted by mean_x
// so that the image Gaussians a model Gaussian can reach are one contiguous range.
struct ImageGaussianArrays {
  std::vector<double> mean_x, mean_y, variance, self_overlap;
  double max_variance = 0.0;
  int size() const { return static_cast<int>(mean_x.size()); }
};

// The image Gaussians [begin, end) that are not beyond `max_mahalanobis_sq` of `p` (overlapValue
// is exactly 0 for every other one): for any pair, d^T S^-1 d >= dx^2 / S_xx, and
// S_xx <= cov_xx + max_variance. Needs `q` sorted by mean_x.
struct OverlapRange {
  int begin = 0, end = 0;
};
OverlapRange overlapRange(const OverlapTerm& p, const ImageGaussianArrays& q,
                          double max_mahalanobis_sq);

// weighted[q] = weight[q] * D_pq for the image Gaussians q in `range` (weight = w_p d(c_p, c_q));
// the others are not written.
void overlapRow(const OverlapTerm& p, const ImageGaussianArrays& q, OverlapRange range,
                const double* weight, double max_mahalanobis_sq, double* weighted);

// Adds the sum over q in `range` of active[q] * d(weighted[q])/d(mean_x, mean_y, cov_xx, cov_xy,
// cov_yy), where weighted = overlapRow's output (the weights do not depend on the pose).
void accumulateOverlapGradient(const OverlapTerm& p, const ImageGaussianArrays& q,
                               OverlapRange range, const double* weighted, const double* active,
                               double gradient[5]);

// The soft part of eq. 8's saturation (EnergyParams::saturation_softness = `softness`): returns
// softness * sum over q of E_qq (1 - exp(-sums[q] / E_qq)) and turns each active[q] (the hard
// cap's derivative, 0 or 1) into (1 - softness) active[q] + softness exp(-sums[q] / E_qq).
double softSaturation(const ImageGaussianArrays& q, const double* sums, double softness,
                      double* active);

}  // namespace sag_hand_tracker
