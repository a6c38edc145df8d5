#include <gtest/gtest.h>

#include "sag_hand_tracker/energy/overlap.h"

#include <Eigen/Dense>
#include <algorithm>
#include <random>

using namespace sag_hand_tracker;

namespace {
double unnormalisedGaussian(const Eigen::Vector2d& x, const Eigen::Vector2d& mean,
                            const Eigen::Matrix2d& cov) {
  const Eigen::Vector2d d = x - mean;
  return std::exp(-0.5 * d.dot(cov.inverse() * d));
}
}  // namespace

// Eq. 7 is the integral of the product of the two un-normalised Gaussians.
TEST(Overlap, MatchesNumericalIntegration) {
  struct Case {
    Eigen::Vector2d mp, mq;
    Eigen::Matrix2d cp, cq;
  };
  std::vector<Case> cases(3);
  cases[0].mp << 1.0, 2.0;
  cases[0].mq << 3.0, 1.0;
  cases[0].cp << 4.0, 1.5, 1.5, 2.0;
  cases[0].cq << 1.0, 0.0, 0.0, 1.0;
  cases[1].mp << 0.0, 0.0;
  cases[1].mq << 0.5, -4.0;
  cases[1].cp << 9.0, -2.0, -2.0, 3.0;
  cases[1].cq << 2.0, 0.8, 0.8, 5.0;
  cases[2].mp << -2.0, 0.0;
  cases[2].mq << 2.0, 0.0;
  cases[2].cp << 0.5, 0.0, 0.0, 8.0;
  cases[2].cq << 0.25, 0.0, 0.0, 0.25;
  for (const Case& c : cases) {
    const double h = 0.02;
    double integral = 0.0;
    for (double x = -25.0; x <= 25.0; x += h) {
      for (double y = -25.0; y <= 25.0; y += h) {
        const Eigen::Vector2d p(x, y);
        integral += unnormalisedGaussian(p, c.mp, c.cp) * unnormalisedGaussian(p, c.mq, c.cq);
      }
    }
    integral *= h * h;
    EXPECT_NEAR(gaussianOverlap(c.mp, c.cp, c.mq, c.cq), integral, 1e-6 * std::max(1.0, integral));
  }
}

TEST(Overlap, IsotropicFormAgreesWithGeneralForm) {
  ProjectedGaussian p;
  p.mean << 10.0, 20.0;
  p.cov << 30.0, -8.0, -8.0, 12.0;
  p.valid = true;
  const OverlapTerm term = prepareOverlapTerm(p);
  for (double sigma : {0.5, 2.0, 6.0}) {
    const Eigen::Vector2d q(13.0, 16.0);
    const double general =
        gaussianOverlap(p.mean, p.cov, q, sigma * sigma * Eigen::Matrix2d::Identity());
    EXPECT_NEAR(overlapIsotropic(term, q.x(), q.y(), sigma * sigma, 1e9, nullptr), general,
                1e-12 * general);
  }
}

TEST(Overlap, IsotropicGradientMatchesCentralDifferences) {
  ProjectedGaussian p;
  p.mean << 10.0, 20.0;
  p.cov << 30.0, -8.0, -8.0, 12.0;
  p.valid = true;
  const double qx = 14.0, qy = 15.0, variance = 4.0;
  OverlapGradient g;
  overlapIsotropic(prepareOverlapTerm(p), qx, qy, variance, 1e9, &g);
  const double analytic[5] = {g.d_mean_x, g.d_mean_y, g.d_cov_xx, g.d_cov_xy, g.d_cov_yy};
  for (int k = 0; k < 5; ++k) {
    auto value = [&](double h) {
      ProjectedGaussian moved = p;
      if (k == 0) moved.mean.x() += h;
      if (k == 1) moved.mean.y() += h;
      if (k == 2) moved.cov(0, 0) += h;
      if (k == 3) {
        moved.cov(0, 1) += h;
        moved.cov(1, 0) += h;
      }
      if (k == 4) moved.cov(1, 1) += h;
      return overlapIsotropic(prepareOverlapTerm(moved), qx, qy, variance, 1e9, nullptr);
    };
    const double h = 1e-5;
    const double numeric = (value(h) - value(-h)) / (2.0 * h);
    EXPECT_NEAR(analytic[k], numeric, 1e-7 * std::max(1.0, std::fabs(numeric)))
        << "component " << k;
  }
}

TEST(Overlap, FarPairsAreCutOff) {
  ProjectedGaussian p;
  p.mean << 0.0, 0.0;
  p.cov = Eigen::Matrix2d::Identity();
  p.valid = true;
  const OverlapTerm term = prepareOverlapTerm(p);
  EXPECT_GT(overlapIsotropic(term, 3.0, 0.0, 1.0, 60.0, nullptr), 0.0);
  EXPECT_EQ(overlapIsotropic(term, 20.0, 0.0, 1.0, 60.0, nullptr), 0.0);
}

// The range of image Gaussians a model Gaussian can reach (sorted by x) holds every pair whose
// overlap is not cut off, and the row over the range is the row over all of them.
TEST(Overlap, RangeHoldsEveryPairWithinTheCutOff) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> position(0.0, 320.0), sigma(0.5, 8.0), spread(1.0, 15.0),
      correlation(-0.9, 0.9);
  const double max_mahalanobis_sq = 60.0;
  int culled = 0, total = 0;
  for (int trial = 0; trial < 50; ++trial) {
    ImageGaussianArrays q;
    std::vector<double> xs(300);
    for (double& x : xs) x = position(rng);
    std::sort(xs.begin(), xs.end());
    for (const double x : xs) {
      const double s = sigma(rng);
      q.mean_x.push_back(x);
      q.mean_y.push_back(position(rng) * 0.75);
      q.variance.push_back(s * s);
      q.self_overlap.push_back(M_PI * s * s);
      q.max_variance = std::max(q.max_variance, s * s);
    }
    ProjectedGaussian projected;
    const double sx = spread(rng), sy = spread(rng), r = correlation(rng);
    projected.mean << position(rng), position(rng) * 0.75;
    projected.cov << sx * sx, r * sx * sy, r * sx * sy, sy * sy;
    projected.valid = true;
    const OverlapTerm term = prepareOverlapTerm(projected);
    const OverlapRange range = overlapRange(term, q, max_mahalanobis_sq);
    ASSERT_LE(0, range.begin);
    ASSERT_LE(range.begin, range.end);
    ASSERT_LE(range.end, q.size());
    const std::vector<float> weight(q.size(), 0.7f);
    std::vector<float> row(q.size(), -1.0f);
    overlapRow(term, q, range, weight.data(), max_mahalanobis_sq, row.data());
    for (int i = 0; i < q.size(); ++i) {
      const double value = 0.7f * overlapIsotropic(term, q.mean_x[i], q.mean_y[i], q.variance[i],
                                                   max_mahalanobis_sq, nullptr);
      if (i < range.begin || i >= range.end) {
        EXPECT_EQ(value, 0.0) << "trial " << trial << ", image Gaussian " << i;
        EXPECT_EQ(row[i], -1.0f);  // not written
        ++culled;
      } else {
        // The row is computed in float (overlap.h); a pair at the cut-off may fall on either
        // side of it, where the value is exp(-30) of its peak.
        EXPECT_NEAR(row[i], value, 1e-5 * std::max(1.0, value));
      }
      ++total;
    }
  }
  // Hand-sized Gaussians in a 320-pixel image: most pairs are out of reach (or the range would
  // be pointless).
  EXPECT_GT(culled, total / 2) << culled << " of " << total;
}
