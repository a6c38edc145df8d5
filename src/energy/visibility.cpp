#include "sag_hand_tracker/energy/visibility.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace sag_hand_tracker {
namespace {

std::optional<Occlusion> occlusion(const VisibilityInputs& in, size_t p, size_t r) {
  if (r == p || !(*in.valid)[r] || !(*in.may_hide)[p * in.may_hide_stride + r]) return std::nullopt;
  const OverlapTerm& tp = (*in.terms)[p];
  const OverlapTerm& tr = (*in.terms)[r];
  const double t_xx = tp.cov_xx + tr.cov_xx, t_xy = tp.cov_xy + tr.cov_xy;
  const double t_yy = tp.cov_yy + tr.cov_yy;
  const double inv_det = 1.0 / (t_xx * t_yy - t_xy * t_xy);
  const double dx = tp.mean_x - tr.mean_x, dy = tp.mean_y - tr.mean_y;
  Occlusion o;
  o.p = p;
  o.r = r;
  o.u_x = (t_yy * dx - t_xy * dy) * inv_det;
  o.u_y = (t_xx * dy - t_xy * dx) * inv_det;
  const double mahalanobis_sq = dx * o.u_x + dy * o.u_y;
  if (!(mahalanobis_sq <= in.max_mahalanobis_sq)) return std::nullopt;
  const double covered = tr.sqrt_det * std::sqrt(inv_det) * std::exp(-0.5 * mahalanobis_sq);
  const double depth_difference = (*in.depths)[p] - (*in.depths)[r];
  const double in_front = 1.0 / (1.0 + std::exp(-depth_difference / in.depth_scale));
  // Below 1, so that no Gaussian is hidden entirely (log v_p stays finite).
  o.amount = std::min(in_front * covered, 1.0 - 1e-9);
  o.behind = 1.0 - in_front;
  o.g_xx = -0.5 * t_yy * inv_det + 0.5 * o.u_x * o.u_x;
  o.g_xy = 0.5 * t_xy * inv_det + 0.5 * o.u_x * o.u_y;
  o.g_yy = -0.5 * t_xx * inv_det + 0.5 * o.u_y * o.u_y;
  return o;
}

}  // namespace

void softVisibility(const VisibilityInputs& in, std::vector<double>* visibility,
                    std::vector<Occlusion>* pairs) {
  const size_t n = in.terms->size();
  visibility->assign(n, 0.0);
  if (pairs) pairs->clear();
  for (size_t p = 0; p < n; ++p) {
    if (!(*in.valid)[p]) continue;
    double log_visible = 0.0;
    for (size_t r = 0; r < n; ++r) {
      if (const std::optional<Occlusion> o = occlusion(in, p, r)) {
        log_visible += std::log1p(-o->amount);
        if (pairs) pairs->push_back(*o);
      }
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
