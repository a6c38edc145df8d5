// The energy's pair loops over the image Gaussians of one camera, written for SIMD: this file is
// compiled with -ffast-math (CMakeLists.txt) so that exp and sqrt vectorise (glibc's libmvec).
// Inputs are finite by construction (PoseEnergy::setFrame filters them, invalid projections are
// skipped), which is what -ffast-math assumes.
#include <algorithm>

#include "sag_hand_tracker/energy/overlap.h"

namespace sag_hand_tracker {

OverlapRange overlapRange(const OverlapTerm& p, const ImageGaussianArrays& q,
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

void overlapRow(const OverlapTerm& term, const ImageGaussianArrays& q, OverlapRange range,
                const double* weight, double max_mahalanobis_sq, double* weighted_out) {
  const OverlapTerm p = term;  // a local copy: no aliasing with the output
  const double* __restrict mean_x = q.mean_x.data();
  const double* __restrict mean_y = q.mean_y.data();
  const double* __restrict variance = q.variance.data();
  double* __restrict weighted = weighted_out;
  for (int i = range.begin; i < range.end; ++i) {
    const OverlapGeometry g = overlapGeometry(p, mean_x[i], mean_y[i], variance[i]);
    weighted[i] = weight[i] * overlapValue(p, g, variance[i], max_mahalanobis_sq);
  }
}

void accumulateOverlapGradient(const OverlapTerm& term, const ImageGaussianArrays& q,
                               OverlapRange range, const double* weighted, const double* active,
                               double gradient[5]) {
  const OverlapTerm p = term;
  const double* mean_x = q.mean_x.data();
  const double* mean_y = q.mean_y.data();
  const double* variance = q.variance.data();
  double g0 = 0.0, g1 = 0.0, g2 = 0.0, g3 = 0.0, g4 = 0.0;
#pragma omp simd reduction(+ : g0, g1, g2, g3, g4)
  for (int i = range.begin; i < range.end; ++i) {
    const OverlapGeometry geometry = overlapGeometry(p, mean_x[i], mean_y[i], variance[i]);
    const OverlapGradient d = overlapGradient(p, geometry, weighted[i] * active[i]);
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

double softSaturation(const ImageGaussianArrays& q, const double* sums, double softness,
                      double* active) {
  const int n = q.size();
  const double* __restrict self_overlap = q.self_overlap.data();
  double* __restrict derivative = active;
  double total = 0.0;
#pragma omp simd reduction(+ : total)
  for (int i = 0; i < n; ++i) {
    const double remaining = std::exp(-sums[i] / self_overlap[i]);
    total += self_overlap[i] * (1.0 - remaining);
    derivative[i] = (1.0 - softness) * derivative[i] + softness * remaining;
  }
  return softness * total;
}

}  // namespace sag_hand_tracker
