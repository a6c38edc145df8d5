#include "sag_hand_tracker/energy/visibility.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace sag_hand_tracker {
namespace {

// What a pair of projected Gaussians p, r shares whichever of them hides the other: T = S_p + S_r,
// u = T^-1 d with d = mu_p - mu_r (negated, bit for bit, for d = mu_r - mu_p), the Mahalanobis
// distance and c's factors sqrt(1 / |T|) and exp(-1/2 d^T T^-1 d). Empty beyond
// max_mahalanobis_sq.
struct PairGeometry {
  double t_xx, t_xy, t_yy, inv_det;
  double u_x, u_y;
  double root_inv_det, gaussian;
};

std::optional<PairGeometry> pairGeometry(const VisibilityInputs& in, size_t p, size_t r) {
  const OverlapTerm& tp = (*in.terms)[p];
  const OverlapTerm& tr = (*in.terms)[r];
  PairGeometry g;
  g.t_xx = tp.cov_xx + tr.cov_xx;
  g.t_xy = tp.cov_xy + tr.cov_xy;
  g.t_yy = tp.cov_yy + tr.cov_yy;
  g.inv_det = 1.0 / (g.t_xx * g.t_yy - g.t_xy * g.t_xy);
  const double dx = tp.mean_x - tr.mean_x, dy = tp.mean_y - tr.mean_y;
  g.u_x = (g.t_yy * dx - g.t_xy * dy) * g.inv_det;
  g.u_y = (g.t_xx * dy - g.t_xy * dx) * g.inv_det;
  const double mahalanobis_sq = dx * g.u_x + dy * g.u_y;
  if (!(mahalanobis_sq <= in.max_mahalanobis_sq)) return std::nullopt;
  g.root_inv_det = std::sqrt(g.inv_det);
  g.gaussian = std::exp(-0.5 * mahalanobis_sq);
  return g;
}

// How much r hides of p, from their PairGeometry (u as seen from p: `sign` -1 when the geometry
// was computed from r).
Occlusion occlusion(const VisibilityInputs& in, size_t p, size_t r, const PairGeometry& g,
                    double sign) {
  const OverlapTerm& tr = (*in.terms)[r];
  Occlusion o;
  o.p = p;
  o.r = r;
  o.u_x = sign * g.u_x;
  o.u_y = sign * g.u_y;
  const double covered = tr.sqrt_det * g.root_inv_det * g.gaussian;
  const double depth_difference = (*in.depths)[p] - (*in.depths)[r];
  const double in_front = 1.0 / (1.0 + std::exp(-depth_difference / in.depth_scale));
  // Below 1, so that no Gaussian is hidden entirely (log v_p stays finite).
  o.amount = std::min(in_front * covered, 1.0 - 1e-9);
  o.behind = 1.0 - in_front;
  o.g_xx = -0.5 * g.t_yy * g.inv_det + 0.5 * o.u_x * o.u_x;
  o.g_xy = 0.5 * g.t_xy * g.inv_det + 0.5 * o.u_x * o.u_y;
  o.g_yy = -0.5 * g.t_xx * g.inv_det + 0.5 * o.u_y * o.u_y;
  return o;
}

}  // namespace

void softVisibility(const VisibilityInputs& in, std::vector<double>* visibility,
                    std::vector<Occlusion>* pairs) {
  const size_t n = in.terms->size();
  visibility->assign(n, 0.0);
  if (pairs) pairs->clear();
  // Each pair's geometry once, for both directions ([p * n + r]: r hides p); then each v_p, its
  // log summed over r in order.
  thread_local std::vector<Occlusion> table;
  thread_local std::vector<char> hides;
  table.resize(n * n);
  hides.assign(n * n, 0);
  for (size_t p = 0; p < n; ++p) {
    if (!(*in.valid)[p]) continue;
    for (size_t r = p + 1; r < n; ++r) {
      if (!(*in.valid)[r]) continue;
      const bool r_hides_p = (*in.may_hide)[p * in.may_hide_stride + r] != 0;
      const bool p_hides_r = (*in.may_hide)[r * in.may_hide_stride + p] != 0;
      if (!r_hides_p && !p_hides_r) continue;
      const std::optional<PairGeometry> geometry = pairGeometry(in, p, r);
      if (!geometry) continue;
      if (r_hides_p) {
        table[p * n + r] = occlusion(in, p, r, *geometry, 1.0);
        hides[p * n + r] = 1;
      }
      if (p_hides_r) {
        table[r * n + p] = occlusion(in, r, p, *geometry, -1.0);
        hides[r * n + p] = 1;
      }
    }
  }
  for (size_t p = 0; p < n; ++p) {
    if (!(*in.valid)[p]) continue;
    double log_visible = 0.0;
    for (size_t r = 0; r < n; ++r) {
      if (!hides[p * n + r]) continue;
      log_visible += std::log1p(-table[p * n + r].amount);
      if (pairs) pairs->push_back(table[p * n + r]);
    }
    (*visibility)[p] = std::exp(log_visible);
  }
}

void accumulateVisibilityGradient(const VisibilityInputs& in, const std::vector<double>& visibility,
                                  const std::vector<Occlusion>& pairs,
                                  const std::vector<double>& d_visibility,
                                  std::vector<ProjectedGradient>* gradient) {
  // dv_p = v_p sum_r -a / (1 - a) d log a, d log a = (1 - s) / depth_scale (dz_p - dz_r)
  // + d log c, with d log c / d mu_p = -u = -d log c / d mu_r, d log c / d S_p = G and
  // d log c / d S_r = G + 1/2 S_r^-1.
  for (const Occlusion& o : pairs) {
    if (d_visibility[o.p] == 0.0) continue;
    const double scale = d_visibility[o.p] * visibility[o.p];
    const OverlapTerm& tr = (*in.terms)[o.r];
    const double k = -scale * o.amount / (1.0 - o.amount);
    const double d_depth = k * o.behind / in.depth_scale;
    ProjectedGradient& gp = (*gradient)[o.p];
    ProjectedGradient& gr = (*gradient)[o.r];
    gp[0] -= k * o.u_x;
    gp[1] -= k * o.u_y;
    gp[2] += k * o.g_xx;
    gp[3] += k * 2.0 * o.g_xy;
    gp[4] += k * o.g_yy;
    gp[5] += d_depth;
    gr[0] += k * o.u_x;
    gr[1] += k * o.u_y;
    gr[2] += k * (o.g_xx + 0.5 * tr.inv_xx);
    gr[3] += k * (2.0 * o.g_xy + tr.inv_xy);
    gr[4] += k * (o.g_yy + 0.5 * tr.inv_yy);
    gr[5] -= d_depth;
  }
}

}  // namespace sag_hand_tracker
