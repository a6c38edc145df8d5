#include "sag_hand_tracker/energy/overlap.h"

#include <Eigen/LU>
#include <cmath>

namespace sag_hand_tracker {

double gaussianOverlap(const Eigen::Vector2d& mean_p, const Eigen::Matrix2d& cov_p,
                       const Eigen::Vector2d& mean_q, const Eigen::Matrix2d& cov_q) {
  const Eigen::Matrix2d sum = cov_p + cov_q;
  const Eigen::Vector2d delta = mean_p - mean_q;
  return 2.0 * M_PI * std::sqrt(cov_p.determinant() * cov_q.determinant() / sum.determinant()) *
         std::exp(-0.5 * delta.dot(sum.inverse() * delta));  // eq. 7
}

OverlapTerm prepareOverlapTerm(const ProjectedGaussian& projected) {
  OverlapTerm term;
  term.mean_x = projected.mean.x();
  term.mean_y = projected.mean.y();
  term.cov_xx = projected.cov(0, 0);
  term.cov_xy = projected.cov(0, 1);
  term.cov_yy = projected.cov(1, 1);
  const double det = term.cov_xx * term.cov_yy - term.cov_xy * term.cov_xy;
  term.sqrt_det = std::sqrt(det);
  term.inv_xx = term.cov_yy / det;
  term.inv_xy = -term.cov_xy / det;
  term.inv_yy = term.cov_xx / det;
  return term;
}

}  // namespace sag_hand_tracker
