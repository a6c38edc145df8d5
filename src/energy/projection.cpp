#include "sag_hand_tracker/energy/projection.h"

#include <cmath>

namespace sag_hand_tracker {
namespace {

// Closest depth (metres) the ellipsoid's 1-sigma extent may reach in front of the camera.
constexpr double kMinDepth = 0.01;

// The projection on the normalised image plane z = 1: centre (x0, y0), shape S.
struct NormalisedEllipse {
  double x0, y0, s_xx, s_xy, s_yy;
};

// Through the intrinsics to pixels (linear: J_pixels = L J_normalised, row by row). Valid only
// when finite and positive definite (a NaN or infinite ellipse fails these tests); the Jacobian is
// written only then.
ProjectedGaussian toPixels(const NormalisedEllipse& e, const Eigen::Matrix3d& K,
                           const Eigen::Matrix<double, 5, 9>* normalised_jacobian,
                           ProjectionJacobian* jacobian) {
  const double fx = K(0, 0), skew = K(0, 1), fy = K(1, 1);
  ProjectedGaussian result;
  const double cov_xx = fx * fx * e.s_xx + 2.0 * fx * skew * e.s_xy + skew * skew * e.s_yy;
  const double cov_xy = fx * fy * e.s_xy + skew * fy * e.s_yy;
  const double cov_yy = fy * fy * e.s_yy;
  result.mean = Eigen::Vector2d(fx * e.x0 + skew * e.y0 + K(0, 2), fy * e.y0 + K(1, 2));
  result.cov << cov_xx, cov_xy, cov_xy, cov_yy;
  result.valid = result.mean.allFinite() && cov_xx > 0.0 && cov_yy > 0.0 &&
                 cov_xx * cov_yy - cov_xy * cov_xy > 0.0 && std::isfinite(cov_xx * cov_yy);
  if (result.valid && jacobian) {
    const Eigen::Matrix<double, 5, 9>& n = *normalised_jacobian;
    jacobian->row(0) = fx * n.row(0) + skew * n.row(1);
    jacobian->row(1) = fy * n.row(1);
    jacobian->row(2) = fx * fx * n.row(2) + 2.0 * fx * skew * n.row(3) + skew * skew * n.row(4);
    jacobian->row(3) = fx * fy * n.row(3) + skew * fy * n.row(4);
    jacobian->row(4) = fy * fy * n.row(4);
  }
  return result;
}

}  // namespace

ProjectedGaussian projectPerspective(const Eigen::Vector3d& mean, const Eigen::Matrix3d& cov,
                                     const Eigen::Matrix3d& K, ProjectionJacobian* jacobian) {
  ProjectedGaussian invalid;
  if (!mean.allFinite() || !cov.allFinite()) return invalid;
  const double mx = mean.x(), my = mean.y(), mz = mean.z();
  const double sxx = cov(0, 0), syy = cov(1, 1), szz = cov(2, 2);
  const double sxy = cov(0, 1), sxz = cov(0, 2), syz = cov(1, 2);
  // The 1-sigma ellipsoid spans mu_z +- sqrt(S_zz) in depth: all of it in front of the camera
  // (which also puts the camera centre outside it).
  if (mz - std::sqrt(std::max(szz, 0.0)) < kMinDepth) return invalid;
  const double det_sigma =
      sxx * (syy * szz - syz * syz) + sxy * (sxz * syz - sxy * szz) + sxz * (sxy * syz - sxz * syy);
  if (!(det_sigma > 0.0)) return invalid;

  // Eqs. 3-5 intersect the tangent cone (M = A mu mu^T A - (mu^T A mu - 1) A, A = Sigma^-1) with
  // the plane z = 1. The same conic in closed form: the ellipsoid's dual quadric projects through
  // [I | 0] to the dual conic C* = Sigma - mu mu^T, whose centre is C*'s last column over C*_zz
  // and whose shape is (c c^T - d B) / d^2 with B its upper-left 2x2, c = C*_(xy, z), d = C*_zz.
  // No inverse of Sigma, and the derivatives are a few products.
  const double b_xx = sxx - mx * mx, b_xy = sxy - mx * my, b_yy = syy - my * my;
  const double c_x = sxz - mx * mz, c_y = syz - my * mz;
  const double d = szz - mz * mz;  // < 0: the depth test above
  const double inv_d = 1.0 / d;
  NormalisedEllipse e;
  e.x0 = c_x * inv_d;
  e.y0 = c_y * inv_d;
  e.s_xx = e.x0 * e.x0 - b_xx * inv_d;
  e.s_xy = e.x0 * e.y0 - b_xy * inv_d;
  e.s_yy = e.y0 * e.y0 - b_yy * inv_d;
  if (!jacobian) return toPixels(e, K, nullptr, nullptr);

  // d(x0, y0, S) / d(b_xx, b_xy, b_yy, c_x, c_y, d), chained with d(b, c, d) / d(mu, Sigma):
  // b_xx = S_xx - mu_x^2, b_xy = S_xy - mu_x mu_y, b_yy = S_yy - mu_y^2, c_x = S_xz - mu_x mu_z,
  // c_y = S_yz - mu_y mu_z, d = S_zz - mu_z^2. Columns: mu (x, y, z), Sigma (xx, yy, zz, xy, xz,
  // yz); rows: x0, y0, S_xx, S_xy, S_yy.
  const double x0 = e.x0, y0 = e.y0;
  const double dxx_dd = (b_xx * inv_d - 2.0 * x0 * x0) * inv_d;  // dS_xx/dd
  const double dxy_dd = (b_xy * inv_d - 2.0 * x0 * y0) * inv_d;
  const double dyy_dd = (b_yy * inv_d - 2.0 * y0 * y0) * inv_d;
  Eigen::Matrix<double, 5, 9> n = Eigen::Matrix<double, 5, 9>::Zero();
  // mu_x: b_xx -2 mu_x, b_xy -mu_y, c_x -mu_z.
  n(0, 0) = -mz * inv_d;
  n(2, 0) = 2.0 * (mx - x0 * mz) * inv_d;
  n(3, 0) = (my - y0 * mz) * inv_d;
  // mu_y: b_xy -mu_x, b_yy -2 mu_y, c_y -mu_z.
  n(1, 1) = -mz * inv_d;
  n(3, 1) = (mx - x0 * mz) * inv_d;
  n(4, 1) = 2.0 * (my - y0 * mz) * inv_d;
  // mu_z: c_x -mu_x, c_y -mu_y, d -2 mu_z.
  n(0, 2) = (2.0 * x0 * mz - mx) * inv_d;
  n(1, 2) = (2.0 * y0 * mz - my) * inv_d;
  n(2, 2) = -2.0 * x0 * mx * inv_d - 2.0 * mz * dxx_dd;
  n(3, 2) = -(y0 * mx + x0 * my) * inv_d - 2.0 * mz * dxy_dd;
  n(4, 2) = -2.0 * y0 * my * inv_d - 2.0 * mz * dyy_dd;
  // Sigma_xx, Sigma_yy: b_xx, b_yy.
  n(2, 3) = -inv_d;
  n(4, 4) = -inv_d;
  // Sigma_zz: d.
  n(0, 5) = -x0 * inv_d;
  n(1, 5) = -y0 * inv_d;
  n(2, 5) = dxx_dd;
  n(3, 5) = dxy_dd;
  n(4, 5) = dyy_dd;
  // Sigma_xy: b_xy.
  n(3, 6) = -inv_d;
  // Sigma_xz: c_x.
  n(0, 7) = inv_d;
  n(2, 7) = 2.0 * x0 * inv_d;
  n(3, 7) = y0 * inv_d;
  // Sigma_yz: c_y.
  n(1, 8) = inv_d;
  n(3, 8) = x0 * inv_d;
  n(4, 8) = 2.0 * y0 * inv_d;
  return toPixels(e, K, &n, jacobian);
}

ProjectedGaussian projectScaledOrthographic(const Eigen::Vector3d& mean, const Eigen::Matrix3d& cov,
                                            const Eigen::Matrix3d& K,
                                            ProjectionJacobian* jacobian) {
  ProjectedGaussian invalid;
  if (!mean.allFinite() || !cov.allFinite()) return invalid;
  const double z = mean.z();
  if (z - std::sqrt(std::max(cov(2, 2), 0.0)) < kMinDepth) return invalid;
  const double inv_z = 1.0 / z;
  const double variance = cov.trace() / 3.0 * inv_z * inv_z;
  if (!(variance > 0.0)) return invalid;
  NormalisedEllipse e{mean.x() * inv_z, mean.y() * inv_z, variance, 0.0, variance};
  if (!jacobian) return toPixels(e, K, nullptr, nullptr);
  Eigen::Matrix<double, 5, 9> n = Eigen::Matrix<double, 5, 9>::Zero();
  n(0, 0) = inv_z;
  n(0, 2) = -e.x0 * inv_z;
  n(1, 1) = inv_z;
  n(1, 2) = -e.y0 * inv_z;
  const double d_trace = inv_z * inv_z / 3.0;
  for (const int row : {2, 4}) {
    n(row, 2) = -2.0 * variance * inv_z;
    n(row, 3) = n(row, 4) = n(row, 5) = d_trace;
  }
  return toPixels(e, K, &n, jacobian);
}

}  // namespace sag_hand_tracker
