#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <random>

#include "sag_hand_tracker/energy/projection.h"
#include "test_support/synthetic_scene.h"

using namespace sag_hand_tracker;

namespace {

Eigen::Matrix3d randomRotation(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Eigen::Quaterniond q(normal(rng), normal(rng), normal(rng), normal(rng));
  return q.normalized().toRotationMatrix();
}

Eigen::Vector2d toPixel(const Eigen::Matrix3d& K, const Eigen::Vector3d& p) {
  return (K * (p / p.z())).head<2>();
}

double ellipseLevel(const ProjectedGaussian& g, const Eigen::Vector2d& x) {
  const Eigen::Vector2d d = x - g.mean;
  return d.dot(g.cov.inverse() * d);
}

struct RandomCase {
  Eigen::Vector3d mean;
  Eigen::Matrix3d cov;
  Eigen::Matrix3d K;
};

// Random anisotropic ellipsoids in front of random (also strongly off-axis) cameras.
RandomCase randomCase(std::mt19937& rng) {
  std::uniform_real_distribution<double> sigma(0.004, 0.05), depth(0.2, 1.2), lateral(-0.6, 0.6),
      focal(150.0, 900.0), centre(100.0, 400.0), skew(-2.0, 2.0);
  RandomCase c;
  const Eigen::Matrix3d R = randomRotation(rng);
  const Eigen::Vector3d s(sigma(rng), sigma(rng), sigma(rng));
  c.cov = R * s.cwiseAbs2().asDiagonal() * R.transpose();
  const double z = depth(rng);
  c.mean = Eigen::Vector3d(lateral(rng) * z, lateral(rng) * z, z);  // up to ~31 degrees off-axis
  c.K << focal(rng), skew(rng), centre(rng), 0.0, focal(rng), centre(rng), 0.0, 0.0, 1.0;
  return c;
}

}  // namespace

// The projected ellipse is the silhouette of the 1-sigma ellipsoid: the contour generator (the
// ellipsoid points whose view ray is tangent) projects exactly onto the ellipse, and every other
// surface point projects inside it. Checked for random ellipsoids and off-axis cameras.
TEST(Projection, PerspectiveMatchesSilhouetteOfOneSigmaEllipsoid) {
  std::mt19937 rng(7);
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 200; ++trial) {
    const RandomCase c = randomCase(rng);
    const ProjectedGaussian projected = projectPerspective(c.mean, c.cov, c.K);
    ASSERT_TRUE(projected.valid) << "trial " << trial;

    // Contour generator: with Sigma = L L^T and w = L^-1 mu, surface points mu + L s with
    // |s| = 1 and s.w = -1 (the polar plane of the camera centre).
    const Eigen::Matrix3d L = c.cov.llt().matrixL();
    const Eigen::Vector3d w = L.triangularView<Eigen::Lower>().solve(c.mean);
    const Eigen::Vector3d s0 = -w / w.squaredNorm();
    const double radius = std::sqrt(1.0 - 1.0 / w.squaredNorm());
    const Eigen::Vector3d e1 = w.unitOrthogonal();
    const Eigen::Vector3d e2 = w.normalized().cross(e1);
    double max_error = 0.0;
    for (int k = 0; k < 64; ++k) {
      const double phi = 2.0 * M_PI * k / 64.0;
      const Eigen::Vector3d s = s0 + radius * (std::cos(phi) * e1 + std::sin(phi) * e2);
      const Eigen::Vector2d pixel = toPixel(c.K, c.mean + L * s);
      max_error = std::max(max_error, std::fabs(ellipseLevel(projected, pixel) - 1.0));
    }
    EXPECT_LT(max_error, 1e-6) << "trial " << trial;

    // All other surface points project inside (level <= 1).
    for (int k = 0; k < 500; ++k) {
      const Eigen::Vector3d s = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
      EXPECT_LE(ellipseLevel(projected, toPixel(c.K, c.mean + L * s)), 1.0 + 1e-9);
    }
  }
}

// Monte-Carlo: the x and y extents of the projected surface points equal the ellipse's extents.
TEST(Projection, ExtentsAgreeWithProjectedSurfacePoints) {
  std::mt19937 rng(11);
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 20; ++trial) {
    const RandomCase c = randomCase(rng);
    const ProjectedGaussian projected = projectPerspective(c.mean, c.cov, c.K);
    ASSERT_TRUE(projected.valid);
    const Eigen::Matrix3d L = c.cov.llt().matrixL();
    Eigen::Vector2d low(1e18, 1e18), high(-1e18, -1e18);
    for (int k = 0; k < 200000; ++k) {
      const Eigen::Vector3d s = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
      const Eigen::Vector2d pixel = toPixel(c.K, c.mean + L * s);
      low = low.cwiseMin(pixel);
      high = high.cwiseMax(pixel);
    }
    const Eigen::Vector2d half_extent(std::sqrt(projected.cov(0, 0)),
                                      std::sqrt(projected.cov(1, 1)));
    const Eigen::Vector2d size = high - low;
    // Sampling converges from inside: tolerance relative to the ellipse size.
    EXPECT_NEAR(high.x(), projected.mean.x() + half_extent.x(), 2e-3 * size.x());
    EXPECT_NEAR(low.x(), projected.mean.x() - half_extent.x(), 2e-3 * size.x());
    EXPECT_NEAR(high.y(), projected.mean.y() + half_extent.y(), 2e-3 * size.y());
    EXPECT_NEAR(low.y(), projected.mean.y() - half_extent.y(), 2e-3 * size.y());
  }
}

TEST(Projection, SphereOnAxisIsCircleAroundPrincipalPoint) {
  Eigen::Matrix3d K;
  K << 300, 0, 160, 0, 300, 120, 0, 0, 1;
  const double r = 0.02, z = 0.5;
  const ProjectedGaussian p =
      projectPerspective(Eigen::Vector3d(0, 0, z), r * r * Eigen::Matrix3d::Identity(), K);
  ASSERT_TRUE(p.valid);
  EXPECT_NEAR(p.mean.x(), 160.0, 1e-9);
  EXPECT_NEAR(p.mean.y(), 120.0, 1e-9);
  // Tangent cone half-angle: sin(a) = r / z; radius on the image = f tan(a).
  const double expected = 300.0 * std::tan(std::asin(r / z));
  EXPECT_NEAR(std::sqrt(p.cov(0, 0)), expected, 1e-9);
  EXPECT_NEAR(p.cov(0, 1), 0.0, 1e-9);
}

TEST(Projection, DegenerateCasesAreInvalidNotNaN) {
  Eigen::Matrix3d K;
  K << 300, 0, 160, 0, 300, 120, 0, 0, 1;
  const Eigen::Matrix3d cov = Eigen::Vector3d(0.05, 0.02, 0.03).cwiseAbs2().asDiagonal();
  // Camera centre inside the ellipsoid.
  EXPECT_FALSE(projectPerspective(Eigen::Vector3d(0, 0, 0.01), cov, K).valid);
  // Behind the camera.
  EXPECT_FALSE(projectPerspective(Eigen::Vector3d(0, 0, -0.5), cov, K).valid);
  // Crossing the camera plane.
  EXPECT_FALSE(projectPerspective(Eigen::Vector3d(0.2, 0, 0.02), cov, K).valid);
  // Singular and non-finite covariances.
  EXPECT_FALSE(projectPerspective(Eigen::Vector3d(0, 0, 0.5), Eigen::Matrix3d::Zero(), K).valid);
  Eigen::Matrix3d nan_cov = cov;
  nan_cov(0, 0) = std::nan("");
  EXPECT_FALSE(projectPerspective(Eigen::Vector3d(0, 0, 0.5), nan_cov, K).valid);
  // Needle-thin ellipsoid seen end-on and grazing: either valid and finite, or invalid.
  const Eigen::Matrix3d needle = Eigen::Vector3d(1e-9, 1e-9, 0.05).cwiseAbs2().asDiagonal();
  const ProjectedGaussian p = projectPerspective(Eigen::Vector3d(0, 0, 0.5), needle, K);
  if (p.valid) {
    EXPECT_TRUE(p.mean.allFinite());
    EXPECT_TRUE(p.cov.allFinite());
  }
  // Scaled orthographic: behind is invalid too.
  EXPECT_FALSE(projectScaledOrthographic(Eigen::Vector3d(0, 0, -0.5), cov, K).valid);
}

TEST(Projection, ScaledOrthographicScalesSigmaWithDepth) {
  Eigen::Matrix3d K;
  K << 300, 0, 160, 0, 300, 120, 0, 0, 1;
  const double sigma = 0.01;
  const ProjectedGaussian p = projectScaledOrthographic(
      Eigen::Vector3d(0.1, -0.05, 0.5), sigma * sigma * Eigen::Matrix3d::Identity(), K);
  ASSERT_TRUE(p.valid);
  EXPECT_NEAR(p.mean.x(), 160.0 + 300.0 * 0.2, 1e-9);
  EXPECT_NEAR(p.mean.y(), 120.0 - 300.0 * 0.1, 1e-9);
  EXPECT_NEAR(std::sqrt(p.cov(0, 0)), 300.0 * sigma / 0.5, 1e-9);
}
