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

// A projected model Gaussian prepared once per (Gaussian, camera) for the pair loop. The pair
// kernels (overlapRow, accumulateOverlapGradient) run in float by default, twice the SIMD lanes
// of double (EnergyParams::float_pairs); everything they feed is summed in double.
template <typename T>
struct OverlapTermOf {
  T mean_x, mean_y;
  T cov_xx, cov_xy, cov_yy;
  T sqrt_det;                // sqrt |Sigma_p|
  T inv_xx, inv_xy, inv_yy;  // Sigma_p^-1

  template <typename U>
  OverlapTermOf<U> cast() const {
    return {U(mean_x),   U(mean_y), U(cov_xx), U(cov_xy), U(cov_yy),
            U(sqrt_det), U(inv_xx), U(inv_xy), U(inv_yy)};
  }
};
using OverlapTerm = OverlapTermOf<double>;
OverlapTerm prepareOverlapTerm(const ProjectedGaussian& projected);

// Derivatives of D_pq with respect to mean_p and the unique entries (xx, xy, yy) of cov_p.
template <typename T>
struct OverlapGradientOf {
  T d_mean_x, d_mean_y;
  T d_cov_xx, d_cov_xy, d_cov_yy;
};
using OverlapGradient = OverlapGradientOf<double>;

// Eq. 7 for an isotropic q (the image Gaussians), the hot loop of the energy, in three inline
// parts so that the vectorised kernels (overlap_kernels.cpp) can reuse them. With
// S = Sigma_p + sigma_q^2 I, d = mu_p - mu_q and u = S^-1 d:
//   D = 2 pi sqrt(|Sigma_p|) sigma_q^2 / sqrt(|S|) exp(-1/2 d^T u)
//   dD/dmu_p = -D u,   dD/dSigma_p = D/2 (Sigma_p^-1 - S^-1 + u u^T).
template <typename T>
struct OverlapGeometryOf {
  T s_xx, s_xy, s_yy, inv_det_s;
  T u_x, u_y;
  T mahalanobis_sq;
};

template <typename T>
inline OverlapGeometryOf<T> overlapGeometry(const OverlapTermOf<T>& p, T mean_x, T mean_y,
                                            T variance_q) {
  OverlapGeometryOf<T> g;
  g.s_xx = p.cov_xx + variance_q;
  g.s_xy = p.cov_xy;
  g.s_yy = p.cov_yy + variance_q;
  g.inv_det_s = T(1) / (g.s_xx * g.s_yy - g.s_xy * g.s_xy);
  const T dx = p.mean_x - mean_x, dy = p.mean_y - mean_y;
  g.u_x = (g.s_yy * dx - g.s_xy * dy) * g.inv_det_s;
  g.u_y = (g.s_xx * dy - g.s_xy * dx) * g.inv_det_s;
  g.mahalanobis_sq = dx * g.u_x + dy * g.u_y;
  return g;
}

// D_pq; 0 beyond `max_mahalanobis_sq` (the pair then contributes < exp(-max/2) of its peak).
// Branch-free so that loops over q vectorise. The exponent is clamped with std::min, not with the
// `far` select: under -ffast-math GCC folds that select into the one after exp, and exp then
// underflows on far pairs, where glibc's vector exp calls its scalar fallback lane by lane.
template <typename T>
inline T overlapValue(const OverlapTermOf<T>& p, const OverlapGeometryOf<T>& g, T variance_q,
                      T max_mahalanobis_sq) {
  const T peak = T(2.0 * M_PI) * p.sqrt_det * variance_q * std::sqrt(g.inv_det_s);
  const bool far = g.mahalanobis_sq > max_mahalanobis_sq;
  const T value = peak * std::exp(T(-0.5) * std::min(g.mahalanobis_sq, max_mahalanobis_sq));
  return far ? T(0) : value;
}

template <typename T>
inline OverlapGradientOf<T> overlapGradient(const OverlapTermOf<T>& p,
                                            const OverlapGeometryOf<T>& g, T value) {
  OverlapGradientOf<T> d;
  d.d_mean_x = -value * g.u_x;
  d.d_mean_y = -value * g.u_y;
  const T half = T(0.5) * value;
  d.d_cov_xx = half * (p.inv_xx - g.s_yy * g.inv_det_s + g.u_x * g.u_x);
  d.d_cov_xy = value * (p.inv_xy + g.s_xy * g.inv_det_s + g.u_x * g.u_y);  // xy and yx together
  d.d_cov_yy = half * (p.inv_yy - g.s_xx * g.inv_det_s + g.u_y * g.u_y);
  return d;
}

// All three together, for one pair.
inline double overlapIsotropic(const OverlapTerm& p, double mean_x, double mean_y,
                               double variance_q, double max_mahalanobis_sq,
                               OverlapGradient* gradient) {
  const OverlapGeometryOf<double> g = overlapGeometry(p, mean_x, mean_y, variance_q);
  const double value = overlapValue(p, g, variance_q, max_mahalanobis_sq);
  if (gradient) *gradient = overlapGradient(p, g, value);
  return value;
}

// Image Gaussians of one camera, structure of arrays for the vectorised kernels, sorted by mean_x
// so that the image Gaussians a model Gaussian can reach are one contiguous range. T is the pair
// kernels' precision (EnergyParams::float_pairs); E_qq is kept in double.
template <typename T>
struct ImageGaussianArraysOf {
  std::vector<T> mean_x, mean_y, variance;
  std::vector<double> self_overlap;
  double max_variance = 0.0;
  int size() const { return static_cast<int>(mean_x.size()); }
};
using ImageGaussianArrays = ImageGaussianArraysOf<float>;

// The image Gaussians [begin, end) that are not beyond `max_mahalanobis_sq` of `p` (overlapValue
// is exactly 0 for every other one): for any pair, d^T S^-1 d >= dx^2 / S_xx, and
// S_xx <= cov_xx + max_variance. Needs `q` sorted by mean_x.
struct OverlapRange {
  int begin = 0, end = 0;
};
template <typename T>
OverlapRange overlapRange(const OverlapTerm& p, const ImageGaussianArraysOf<T>& q,
                          double max_mahalanobis_sq);

// weighted[q] = weight[q] * D_pq for the image Gaussians q in `range` (weight = w_p d(c_p, c_q));
// the others are not written. Computed in T.
template <typename T>
void overlapRow(const OverlapTerm& p, const ImageGaussianArraysOf<T>& q, OverlapRange range,
                const T* weight, double max_mahalanobis_sq, T* weighted);

// Adds the sum over q in `range` of active[q] * d(weighted[q])/d(mean_x, mean_y, cov_xx, cov_xy,
// cov_yy), where weighted = overlapRow's output (the weights do not depend on the pose).
template <typename T>
void accumulateOverlapGradient(const OverlapTerm& p, const ImageGaussianArraysOf<T>& q,
                               OverlapRange range, const T* weighted, const T* active,
                               double gradient[5]);

// The soft part of eq. 8's saturation (EnergyParams::saturation_softness = `softness`): returns
// softness * sum over q of E_qq (1 - exp(-sums[q] / E_qq)) and turns each active[q] (the hard
// cap's derivative, 0 or 1) into (1 - softness) active[q] + softness exp(-sums[q] / E_qq).
template <typename T>
double softSaturation(const ImageGaussianArraysOf<T>& q, const double* sums, double softness,
                      T* active);

}  // namespace sag_hand_tracker
