#include "sag_hand_tracker/energy/projection.h"

#include "projection_impl.h"

namespace sag_hand_tracker {
namespace {

using ProjectFunction = bool (*)(const double*, const double*, const Eigen::Matrix3d&,
                                 detail::Projection2D<double>*);

ProjectedGaussian project(ProjectFunction function, const Eigen::Vector3d& mean,
                          const Eigen::Matrix3d& cov, const Eigen::Matrix3d& K) {
  const double mu[3] = {mean.x(), mean.y(), mean.z()};
  const double sigma[6] = {cov(0, 0), cov(1, 1), cov(2, 2), cov(0, 1), cov(0, 2), cov(1, 2)};
  detail::Projection2D<double> p;
  ProjectedGaussian result;
  if (!mean.allFinite() || !cov.allFinite() || !function(mu, sigma, K, &p)) return result;
  result.mean = Eigen::Vector2d(p.mean_x, p.mean_y);
  result.cov << p.cov_xx, p.cov_xy, p.cov_xy, p.cov_yy;
  result.valid = true;
  return result;
}

}  // namespace

ProjectedGaussian projectPerspective(const Eigen::Vector3d& mean, const Eigen::Matrix3d& cov,
                                     const Eigen::Matrix3d& K) {
  return project(&detail::projectPerspectiveGeneric<double>, mean, cov, K);
}

ProjectedGaussian projectScaledOrthographic(const Eigen::Vector3d& mean, const Eigen::Matrix3d& cov,
                                            const Eigen::Matrix3d& K) {
  return project(&detail::projectScaledOrthographicGeneric<double>, mean, cov, K);
}

}  // namespace sag_hand_tracker
