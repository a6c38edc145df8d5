// How much of each projected model Gaussian a camera sees past the model Gaussians in front of
// it: a soft, differentiable depth order (issue 9: curled fingers; issue 11: an energy that cannot
// cheat).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "sag_hand_tracker/energy/overlap.h"

namespace sag_hand_tracker {

// The visibility of p in one camera:
//   v_p = prod_{r != p} (1 - s_rp c_pr),
//   c_pr = sqrt(|S_r| / |S_p + S_r|) exp(-1/2 d^T (S_p + S_r)^-1 d), d = mu_p - mu_r,
//   s_rp = 1 / (1 + exp(-(z_p - z_r) / depth_scale)).
// c_pr in [0, 1] is how much of p's mass r covers (eq. 7's overlap of p and r over p's with
// itself, halved: 1 for an r infinitely wide over p, 1/2 for an equal r on it); s_rp is how
// surely r is in front of p (z: depth along the camera's axis). Two Gaussians at one depth hide
// each other's common part half each, so that overlapping Gaussians of one finger count about
// their union; a finger curled behind the palm is almost hidden. Pairs beyond max_mahalanobis_sq
// are left out (c < exp(-max/2)), and so are the pairs that `may_hide` leaves out; `valid[p]`
// false: p neither hides nor is seen (0).
struct VisibilityInputs {
  const std::vector<OverlapTerm>* terms;
  const std::vector<double>* depths;
  const std::vector<char>* valid;
  const std::vector<char>* may_hide;  // [p * may_hide_stride + r]: whether r may hide p at all
  // The row length of may_hide: at least terms->size(), so that one table serves the hand with
  // and without the forearm's Gaussians after it.
  size_t may_hide_stride;
  double depth_scale;  // > 0
  double max_mahalanobis_sq;
};
// How much of p the Gaussian r hides (a = s_rp c_pr), with what the derivatives need.
struct Occlusion {
  size_t p, r;              // p hidden by r
  double amount;            // a
  double behind;            // 1 - s_rp
  double u_x, u_y;          // (S_p + S_r)^-1 d
  double g_xx, g_xy, g_yy;  // d log c / d S_p as a symmetric matrix: -1/2 T^-1 + 1/2 u u^T
};
// With `pairs`, also every pair that hides, p by p: what accumulateVisibilityGradient needs, so
// that an evaluation with a gradient computes each pair's exponentials once.
void softVisibility(const VisibilityInputs& inputs, std::vector<double>* visibility,
                    std::vector<Occlusion>* pairs = nullptr);

// Derivatives with respect to one projected Gaussian: its 2D mean (x, y), the unique entries of
// its 2D covariance (xx, xy as one entry, yy; OverlapGradient's convention) and its depth.
using ProjectedGradient = Eigen::Matrix<double, 6, 1>;

// Adds to `gradient` (one entry per Gaussian) the derivatives of sum_p g_p v_p for the given
// g_p = dE/dv_p (`visibility` and `pairs` from one softVisibility).
void accumulateVisibilityGradient(const VisibilityInputs& inputs,
                                  const std::vector<double>& visibility,
                                  const std::vector<Occlusion>& pairs,
                                  const std::vector<double>& d_visibility,
                                  std::vector<ProjectedGradient>* gradient);

}  // namespace sag_hand_tracker
