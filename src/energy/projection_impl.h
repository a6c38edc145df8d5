// Scalar-generic projection (double, or Eigen's forward-mode AutoDiffScalar for the exact
// Jacobian used by the energy gradient). Private to the core library.
#pragma once

#include <Eigen/Core>
#include <cmath>

namespace sag_hand_tracker {
namespace detail {

// Closest depth (metres) the ellipsoid's 1-sigma extent may reach in front of the camera.
constexpr double kMinDepth = 0.01;

template <typename T>
struct Projection2D {
  T mean_x, mean_y;
  T cov_xx, cov_xy, cov_yy;
};

inline double valueOf(double x) { return x; }
template <typename T>
double valueOf(const T& x) {
  return x.value();
}

// Inputs: mean (3) and the unique covariance entries (xx, yy, zz, xy, xz, yz), camera frame.
template <typename T>
bool projectPerspectiveGeneric(const T* mu, const T* cov, const Eigen::Matrix3d& K,
                               Projection2D<T>* out) {
  using std::sqrt;
  // The ellipsoid must lie entirely in front of the camera: its lowest z is mu_z - sqrt(S_zz).
  if (valueOf(mu[2]) - std::sqrt(std::max(valueOf(cov[2]), 0.0)) < kMinDepth) return false;

  // A = Sigma^-1 by cofactors (symmetric).
  const T& sxx = cov[0];
  const T& syy = cov[1];
  const T& szz = cov[2];
  const T& sxy = cov[3];
  const T& sxz = cov[4];
  const T& syz = cov[5];
  const T c_xx = syy * szz - syz * syz;
  const T c_xy = sxz * syz - sxy * szz;
  const T c_xz = sxy * syz - sxz * syy;
  const T det_sigma = sxx * c_xx + sxy * c_xy + sxz * c_xz;
  if (!(valueOf(det_sigma) > 0.0)) return false;
  const T inv_det = T(1.0) / det_sigma;
  const T a_xx = c_xx * inv_det, a_xy = c_xy * inv_det, a_xz = c_xz * inv_det;
  const T a_yy = (sxx * szz - sxz * sxz) * inv_det;
  const T a_yz = (sxz * sxy - sxx * syz) * inv_det;
  const T a_zz = (sxx * syy - sxy * sxy) * inv_det;

  // Cone matrix (eq. 5): M = A mu mu^T A - (mu^T A mu - 1) A = b b^T - k A.
  const T b_x = a_xx * mu[0] + a_xy * mu[1] + a_xz * mu[2];
  const T b_y = a_xy * mu[0] + a_yy * mu[1] + a_yz * mu[2];
  const T b_z = a_xz * mu[0] + a_yz * mu[1] + a_zz * mu[2];
  const T k = mu[0] * b_x + mu[1] * b_y + mu[2] * b_z - T(1.0);
  if (!(valueOf(k) > 1e-9)) return false;  // camera centre inside the 1-sigma ellipsoid
  const T m_xx = b_x * b_x - k * a_xx;
  const T m_xy = b_x * b_y - k * a_xy;
  const T m_yy = b_y * b_y - k * a_yy;
  const T m_xz = b_x * b_z - k * a_xz;
  const T m_yz = b_y * b_z - k * a_yz;
  const T m_zz = b_z * b_z - k * a_zz;

  // On the plane z = 1 the cone is the conic x^T M33 x + 2 m^T x + m_zz = 0 (M33 = upper-left
  // 2x2). Centre x0 = -M33^-1 m (eq. 3, the minors |M31|, |M23| over |M33|), shape
  // -|M|/|M33| M33^-1 (eq. 4).
  const T det_m33 = m_xx * m_yy - m_xy * m_xy;
  if (!(std::fabs(valueOf(det_m33)) > 1e-300)) return false;
  const T inv_det_m33 = T(1.0) / det_m33;
  const T x0 = -(m_yy * m_xz - m_xy * m_yz) * inv_det_m33;
  const T y0 = -(m_xx * m_yz - m_xy * m_xz) * inv_det_m33;
  const T det_m = m_xx * (m_yy * m_zz - m_yz * m_yz) - m_xy * (m_xy * m_zz - m_yz * m_xz) +
                  m_xz * (m_xy * m_yz - m_yy * m_xz);
  const T scale = -det_m * inv_det_m33 * inv_det_m33;  // -|M|/|M33| times 1/|M33| of the inverse
  const T n_xx = scale * m_yy;
  const T n_xy = -scale * m_xy;
  const T n_yy = scale * m_xx;

  // Through K33 to pixels.
  const double fx = K(0, 0), skew = K(0, 1), fy = K(1, 1);
  out->mean_x = fx * x0 + skew * y0 + K(0, 2);
  out->mean_y = fy * y0 + K(1, 2);
  out->cov_xx = fx * fx * n_xx + 2.0 * fx * skew * n_xy + skew * skew * n_yy;
  out->cov_xy = fx * fy * n_xy + skew * fy * n_yy;
  out->cov_yy = fy * fy * n_yy;

  const double vxx = valueOf(out->cov_xx), vxy = valueOf(out->cov_xy), vyy = valueOf(out->cov_yy);
  return std::isfinite(valueOf(out->mean_x)) && std::isfinite(valueOf(out->mean_y)) && vxx > 0.0 &&
         vyy > 0.0 && vxx * vyy - vxy * vxy > 0.0 && std::isfinite(vxx * vyy);
}

// Scaled orthographic projection of an isotropic Gaussian (SoG baseline): sigma_2D = f sigma / z.
template <typename T>
bool projectScaledOrthographicGeneric(const T* mu, const T* cov, const Eigen::Matrix3d& K,
                                      Projection2D<T>* out) {
  if (valueOf(mu[2]) - std::sqrt(std::max(valueOf(cov[2]), 0.0)) < kMinDepth) return false;
  const T inv_z = T(1.0) / mu[2];
  const T x = mu[0] * inv_z;
  const T y = mu[1] * inv_z;
  const T variance = (cov[0] + cov[1] + cov[2]) * (1.0 / 3.0) * inv_z * inv_z;
  if (!(valueOf(variance) > 0.0)) return false;
  const double fx = K(0, 0), skew = K(0, 1), fy = K(1, 1);
  out->mean_x = fx * x + skew * y + K(0, 2);
  out->mean_y = fy * y + K(1, 2);
  out->cov_xx = fx * fx * variance;
  out->cov_xy = T(0.0) * variance;
  out->cov_yy = fy * fy * variance;
  return true;
}

}  // namespace detail
}  // namespace sag_hand_tracker
