// The energy's pair loops over the image Gaussians of one camera, written for SIMD: this file is
// compiled with -ffast-math (CMakeLists.txt) so that exp and sqrt vectorise (glibc's libmvec).
// Inputs are finite by construction (PoseEnergy::setFrame filters them, invalid projections are
// skipped), which is what -ffast-math assumes.
#include <algorithm>

#include "sag_hand_tracker/energy/overlap.h"

namespace sag_hand_tracker {

template <typename T>
OverlapRange overlapRange(const OverlapTerm& p, const ImageGaussianArraysOf<T>& q,
                          double max_mahalanobis_sq) {
  // A relative margin far above rounding keeps every pair that overlapValue could keep.
  const double half_width =
      (1.0 + 1e-6) * std::sqrt(max_mahalanobis_sq * (p.cov_xx + q.max_variance));
  const auto first = q.mean_x.begin();
  OverlapRange range;
  range.begin =
      static_cast<int>(std::lower_bound(first, q.mean_x.end(), p.mean_x - half_width) - first);
  range.end = static_cast<int>(
      std::upper_bound(first + range.begin, q.mean_x.end(), p.mean_x + half_width) - first);
  return range;
}

template <typename T>
void overlapRow(const OverlapTerm& term, const ImageGaussianArraysOf<T>& q, OverlapRange range,
                const T* weight, double max_mahalanobis_sq, T* weighted_out) {
  const OverlapTermOf<T> p = term.cast<T>();  // a local copy: no aliasing with the output
  const T max_sq = static_cast<T>(max_mahalanobis_sq);
  const T* __restrict mean_x = q.mean_x.data();
  const T* __restrict mean_y = q.mean_y.data();
  const T* __restrict variance = q.variance.data();
  T* __restrict weighted = weighted_out;
  for (int i = range.begin; i < range.end; ++i) {
    const OverlapGeometryOf<T> g = overlapGeometry(p, mean_x[i], mean_y[i], variance[i]);
    weighted[i] = weight[i] * overlapValue(p, g, variance[i], max_sq);
  }
}

template <typename T>
void accumulateOverlapGradient(const OverlapTerm& term, const ImageGaussianArraysOf<T>& q,
                               OverlapRange range, const T* weighted, const T* active,
                               double gradient[5]) {
  const OverlapTermOf<T> p = term.cast<T>();
  const T* mean_x = q.mean_x.data();
  const T* mean_y = q.mean_y.data();
  const T* variance = q.variance.data();
  T g0 = 0, g1 = 0, g2 = 0, g3 = 0, g4 = 0;
#pragma omp simd reduction(+ : g0, g1, g2, g3, g4)
  for (int i = range.begin; i < range.end; ++i) {
    const OverlapGeometryOf<T> geometry = overlapGeometry(p, mean_x[i], mean_y[i], variance[i]);
    const OverlapGradientOf<T> d = overlapGradient(p, geometry, weighted[i] * active[i]);
    g0 += d.d_mean_x;
    g1 += d.d_mean_y;
    g2 += d.d_cov_xx;
    g3 += d.d_cov_xy;
    g4 += d.d_cov_yy;
  }
  gradient[0] += g0;
  gradient[1] += g1;
  gradient[2] += g2;
  gradient[3] += g3;
  gradient[4] += g4;
}

template <typename T>
double softSaturation(const ImageGaussianArraysOf<T>& q, const double* sums, double softness,
                      T* active) {
  const int n = q.size();
  const double* __restrict self_overlap = q.self_overlap.data();
  T* __restrict derivative = active;
  double total = 0.0;
#pragma omp simd reduction(+ : total)
  for (int i = 0; i < n; ++i) {
    const double remaining = std::exp(-sums[i] / self_overlap[i]);
    total += self_overlap[i] * (1.0 - remaining);
    derivative[i] = static_cast<T>((1.0 - softness) * derivative[i] + softness * remaining);
  }
  return softness * total;
}

#define SAG_INSTANTIATE_OVERLAP_KERNELS(T)                                                         \
  template OverlapRange overlapRange(const OverlapTerm&, const ImageGaussianArraysOf<T>&, double); \
  template void overlapRow(const OverlapTerm&, const ImageGaussianArraysOf<T>&, OverlapRange,      \
                           const T*, double, T*);                                                  \
  template void accumulateOverlapGradient(const OverlapTerm&, const ImageGaussianArraysOf<T>&,     \
                                          OverlapRange, const T*, const T*, double[5]);            \
  template double softSaturation(const ImageGaussianArraysOf<T>&, const double*, double, T*);
SAG_INSTANTIATE_OVERLAP_KERNELS(float)
SAG_INSTANTIATE_OVERLAP_KERNELS(double)
#undef SAG_INSTANTIATE_OVERLAP_KERNELS

}  // namespace sag_hand_tracker
