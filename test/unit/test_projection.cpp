#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <random>

#include "sag_hand_tracker/energy/hand_projection.h"
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

namespace {

// The paper's construction, eqs. 3-5, written out as in the paper: the cone matrix
// M = A mu mu^T A - (mu^T A mu - 1) A with A = Sigma^-1, its section with z = 1 (centre from the
// minors, shape -|M| / |M33| M33^-1), then through K.
ProjectedGaussian coneProjection(const Eigen::Vector3d& mu, const Eigen::Matrix3d& sigma,
                                 const Eigen::Matrix3d& K) {
  const Eigen::Matrix3d A = sigma.inverse();
  const Eigen::Vector3d b = A * mu;
  const Eigen::Matrix3d M = b * b.transpose() - (mu.dot(b) - 1.0) * A;
  const Eigen::Matrix2d M33 = M.topLeftCorner<2, 2>();
  const Eigen::Vector2d centre = -M33.inverse() * M.topRightCorner<2, 1>();
  const Eigen::Matrix2d shape = -M.determinant() / M33.determinant() * M33.inverse();
  const Eigen::Matrix2d K2 = K.topLeftCorner<2, 2>();
  ProjectedGaussian result;
  result.mean = K2 * centre + K.topRightCorner<2, 1>();
  result.cov = K2 * shape * K2.transpose();
  result.valid = true;
  return result;
}

Eigen::Matrix<double, 5, 1> packed(const ProjectedGaussian& g) {
  Eigen::Matrix<double, 5, 1> v;
  v << g.mean.x(), g.mean.y(), g.cov(0, 0), g.cov(0, 1), g.cov(1, 1);
  return v;
}

// Central differences of a projection over (mu, unique Sigma), the Jacobian's column order.
template <typename Project>
ProjectionJacobian numericJacobian(Project project, const RandomCase& c) {
  ProjectionJacobian numeric;
  const int unique_row[6] = {0, 1, 2, 0, 0, 1}, unique_col[6] = {0, 1, 2, 1, 2, 2};
  for (int k = 0; k < 9; ++k) {
    const double h = k < 3 ? 1e-7 : 1e-10;
    Eigen::Vector3d mean_plus = c.mean, mean_minus = c.mean;
    Eigen::Matrix3d cov_plus = c.cov, cov_minus = c.cov;
    if (k < 3) {
      mean_plus[k] += h;
      mean_minus[k] -= h;
    } else {
      const int i = unique_row[k - 3], j = unique_col[k - 3];
      cov_plus(i, j) += h;
      cov_minus(i, j) -= h;
      if (i != j) {
        cov_plus(j, i) += h;
        cov_minus(j, i) -= h;
      }
    }
    numeric.col(k) =
        (packed(project(mean_plus, cov_plus, c.K)) - packed(project(mean_minus, cov_minus, c.K))) /
        (2.0 * h);
  }
  return numeric;
}

}  // namespace

// The closed form (the dual conic Sigma - mu mu^T) is the same ellipse as the paper's cone.
TEST(Projection, PerspectiveEqualsThePapersConeConstruction) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 200; ++trial) {
    const RandomCase c = randomCase(rng);
    const ProjectedGaussian projected = projectPerspective(c.mean, c.cov, c.K);
    const ProjectedGaussian cone = coneProjection(c.mean, c.cov, c.K);
    ASSERT_TRUE(projected.valid) << "trial " << trial;
    const Eigen::Matrix<double, 5, 1> difference = packed(projected) - packed(cone);
    EXPECT_LT(difference.cwiseAbs().maxCoeff(), 1e-9 * packed(cone).cwiseAbs().maxCoeff())
        << "trial " << trial << ": " << difference.transpose();
  }
}

// The exact Jacobian the energy gradient chains through, against central differences, for both
// projections (the SoG baseline's only depends on the trace of Sigma).
TEST(Projection, JacobiansMatchCentralDifferences) {
  std::mt19937 rng(9);
  for (int trial = 0; trial < 100; ++trial) {
    const RandomCase c = randomCase(rng);
    for (const bool perspective : {true, false}) {
      const auto project = [perspective](const Eigen::Vector3d& mean, const Eigen::Matrix3d& cov,
                                         const Eigen::Matrix3d& K) {
        return perspective ? projectPerspective(mean, cov, K)
                           : projectScaledOrthographic(mean, cov, K);
      };
      ProjectionJacobian jacobian;
      jacobian.setConstant(std::nan(""));
      const ProjectedGaussian projected =
          perspective ? projectPerspective(c.mean, c.cov, c.K, &jacobian)
                      : projectScaledOrthographic(c.mean, c.cov, c.K, &jacobian);
      ASSERT_TRUE(projected.valid);
      // The value path with and without the Jacobian is the same.
      EXPECT_EQ(packed(projected), packed(project(c.mean, c.cov, c.K)));
      ASSERT_TRUE(jacobian.allFinite()) << "trial " << trial;
      const ProjectionJacobian numeric = numericJacobian(project, c);
      for (int row = 0; row < 5; ++row) {
        const double scale = numeric.row(row).cwiseAbs().maxCoeff() + 1e-6;
        EXPECT_LT((jacobian.row(row) - numeric.row(row)).cwiseAbs().maxCoeff(), 1e-5 * scale)
            << "trial " << trial << (perspective ? " perspective" : " orthographic") << ", row "
            << row << "\nexact   " << jacobian.row(row) << "\nnumeric " << numeric.row(row);
      }
    }
  }
}

// projectDistorted is where the camera delivers a point: undistorting that pixel gives the pinhole
// projection back (plumb_bob, strong barrel distortion, points over the whole image).
TEST(Projection, ProjectDistortedIsTheInverseOfUndistortPixel) {
  Camera camera;
  camera.width = 640;
  camera.height = 480;
  camera.K << 500.0, 0.0, 320.0, 0.0, 500.0, 240.0, 0.0, 0.0, 1.0;
  camera.distortion = {-0.3, 0.1, 0.001, -0.002, 0.0};
  for (const double x : {-0.25, 0.0, 0.3}) {
    for (const double y : {-0.2, 0.05, 0.2}) {
      const Eigen::Vector3d point(x, y, 0.5);
      Eigen::Vector2d ideal, delivered;
      ASSERT_TRUE(camera.project(point, &ideal));
      ASSERT_TRUE(camera.projectDistorted(point, &delivered));
      // undistortPixel iterates as often as cv::undistortPoints does by default: 0.1 pixel.
      EXPECT_LT((camera.undistortPixel(delivered) - ideal).norm(), 0.1) << x << " " << y;
      if (std::abs(x) > 0.2) EXPECT_GT((delivered - ideal).norm(), 5.0);  // it does distort
    }
  }
  Eigen::Vector2d pixel;
  EXPECT_FALSE(camera.projectDistorted(Eigen::Vector3d(0.0, 0.0, -0.5), &pixel));  // behind
  camera.distortion.clear();
  ASSERT_TRUE(camera.projectDistorted(Eigen::Vector3d(0.1, 0.0, 0.5), &pixel));
  EXPECT_NEAR(pixel.x(), 420.0, 1e-9);
}

// fillEllipse sets exactly the pixels whose centres lie inside the ellipse, and returns their
// bounding rectangle: random ellipses of 0.2 to 80 pixels, at any angle, some cut by the border.
TEST(FillEllipse, SetsExactlyThePixelCentresInside) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> centre(-30.0, 110.0), axis(0.2, 80.0), angle(-180, 180);
  for (int trial = 0; trial < 300; ++trial) {
    const cv::RotatedRect box(cv::Point2f(centre(rng), centre(rng)),
                              cv::Size2f(axis(rng), axis(rng)), angle(rng));
    cv::Mat mask(64, 96, CV_8UC1, cv::Scalar(0));
    const cv::Rect filled = fillEllipse(box, &mask);
    const double a = 0.5 * box.size.width, b = 0.5 * box.size.height;
    const double t = box.angle * M_PI / 180.0;
    cv::Rect expected;
    for (int y = 0; y < mask.rows; ++y) {
      for (int x = 0; x < mask.cols; ++x) {
        const double dx = x - box.center.x, dy = y - box.center.y;
        const double u = std::cos(t) * dx + std::sin(t) * dy;
        const double v = -std::sin(t) * dx + std::cos(t) * dy;
        const double level = (u / a) * (u / a) + (v / b) * (v / b);
        const bool set = mask.at<std::uint8_t>(y, x) == 255;
        if (set) expected |= cv::Rect(x, y, 1, 1);
        if (std::fabs(level - 1.0) < 1e-6) continue;  // on the boundary, within rounding
        ASSERT_EQ(set, level < 1.0)
            << "trial " << trial << " pixel " << x << "," << y << " level " << level;
        ASSERT_TRUE(set || mask.at<std::uint8_t>(y, x) == 0);
      }
    }
    EXPECT_EQ(filled, expected) << "trial " << trial;
  }
}

// The same ellipse as cv::ellipse draws (axes, angle and pixel convention): on ellipses of 6 to 60
// pixels the two differ only along the outline, by less than its length in pixels.
TEST(FillEllipse, AgreesWithOpenCvsEllipseUpToTheOutline) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> centre(20.0, 80.0), axis(6.0, 60.0), angle(-180, 180);
  for (int trial = 0; trial < 100; ++trial) {
    const cv::RotatedRect box(cv::Point2f(centre(rng), centre(rng)),
                              cv::Size2f(axis(rng), axis(rng)), angle(rng));
    cv::Mat ours(100, 100, CV_8UC1, cv::Scalar(0)), opencv = ours.clone();
    fillEllipse(box, &ours);
    cv::ellipse(opencv, box, cv::Scalar(255), cv::FILLED);
    const double a = 0.5 * box.size.width, b = 0.5 * box.size.height;
    const double outline = M_PI * (3.0 * (a + b) - std::sqrt((3.0 * a + b) * (a + 3.0 * b)));
    EXPECT_LT(cv::countNonZero(ours != opencv), outline) << "trial " << trial;
    EXPECT_GT(cv::countNonZero(ours & opencv), 0.8 * M_PI * a * b) << "trial " << trial;
  }
}

TEST(FillEllipse, DegenerateEllipsesSetNothing) {
  cv::Mat mask(20, 20, CV_8UC1, cv::Scalar(0));
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (const cv::RotatedRect& box :
       {cv::RotatedRect(cv::Point2f(10, 10), cv::Size2f(0, 5), 0),
        cv::RotatedRect(cv::Point2f(10, 10), cv::Size2f(-3, 5), 0),
        cv::RotatedRect(cv::Point2f(nan, 10), cv::Size2f(3, 5), 0),
        cv::RotatedRect(cv::Point2f(10, 10), cv::Size2f(inf, 5), 0),
        cv::RotatedRect(cv::Point2f(10, 10), cv::Size2f(3, 5), nan),
        cv::RotatedRect(cv::Point2f(10.5f, 10.5f), cv::Size2f(0.4f, 0.4f), 0),  // between centres
        cv::RotatedRect(cv::Point2f(-50, 10), cv::Size2f(10, 10), 0),
        cv::RotatedRect(cv::Point2f(1e30f, 1e30f), cv::Size2f(1e20f, 3), 45),  // far off
        cv::RotatedRect(cv::Point2f(10, 1e30f), cv::Size2f(3, 5), 0)}) {
    EXPECT_TRUE(fillEllipse(box, &mask).empty());
  }
  EXPECT_EQ(cv::countNonZero(mask), 0);
  cv::Mat colour(20, 20, CV_8UC3, cv::Scalar::all(0));
  EXPECT_THROW(fillEllipse(cv::RotatedRect(cv::Point2f(10, 10), cv::Size2f(3, 5), 0), &colour),
               InputError);
}
