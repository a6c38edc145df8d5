// The soft depth order of visibility.h: its values in simple cases and its derivatives.
#include <gtest/gtest.h>

#include <random>

#include "sag_hand_tracker/energy/visibility.h"

namespace sag_hand_tracker {
namespace {

OverlapTerm term(double x, double y, double xx, double xy, double yy) {
  ProjectedGaussian projected;
  projected.mean = Eigen::Vector2d(x, y);
  projected.cov << xx, xy, xy, yy;
  projected.valid = true;
  return prepareOverlapTerm(projected);
}

struct Scene {
  std::vector<OverlapTerm> terms;
  std::vector<double> depths;
  std::vector<char> valid, may_hide;
  VisibilityInputs inputs(double depth_scale) const {
    return {&terms, &depths, &valid, &may_hide, terms.size(), depth_scale, 1e9};
  }
};

Scene twoGaussians(double depth_a, double depth_b, double offset) {
  Scene scene;
  scene.terms = {term(0, 0, 4, 0, 4), term(offset, 0, 4, 0, 4)};
  scene.depths = {depth_a, depth_b};
  scene.valid = {1, 1};
  scene.may_hide = {0, 1, 1, 0};
  return scene;
}

}  // namespace

// A Gaussian well behind an equal one on top of it keeps half of itself (c = 1/2), the one in
// front all of it; at one depth each keeps 3/4; apart, both stay whole; a pair that may not hide
// each other (one surface) stays whole however it lies.
TEST(Visibility, HidesWhatIsBehindAndOnTop) {
  std::vector<double> v;
  Scene scene = twoGaussians(0.5, 0.3, 0.0);
  softVisibility(scene.inputs(0.005), &v);
  EXPECT_NEAR(v[0], 0.5, 1e-6);
  EXPECT_NEAR(v[1], 1.0, 1e-6);
  scene = twoGaussians(0.4, 0.4, 0.0);
  softVisibility(scene.inputs(0.005), &v);
  EXPECT_NEAR(v[0], 0.75, 1e-12);
  EXPECT_NEAR(v[1], 0.75, 1e-12);
  scene = twoGaussians(0.5, 0.3, 40.0);
  softVisibility(scene.inputs(0.005), &v);
  EXPECT_NEAR(v[0], 1.0, 1e-12);
  scene = twoGaussians(0.5, 0.3, 0.0);
  scene.may_hide = {0, 0, 0, 0};
  softVisibility(scene.inputs(0.005), &v);
  EXPECT_EQ(v[0], 1.0);
  scene.valid = {1, 0};  // an unprojectable Gaussian hides nothing and is not seen
  scene.may_hide = {0, 1, 1, 0};
  softVisibility(scene.inputs(0.005), &v);
  EXPECT_EQ(v[0], 1.0);
  EXPECT_EQ(v[1], 0.0);
}

// The energy keeps one table for the hand's Gaussians with and without the forearm's after them:
// its rows are longer than the Gaussians projected. Read with the table's own row length, the
// hand alone sees the pairs the table gives it (until session 29 it was read with the number of
// Gaussians projected, and the hand without its forearm got another pair's entries).
TEST(Visibility, ReadsTheTableWithItsOwnRowLength) {
  Scene scene = twoGaussians(0.3, 0.5, 0.0);  // 0 in front of 1, on top of it
  // A table of three Gaussians (the third not projected this time) in which 0 may not hide 1
  // ([1 * 3 + 0] = 0) and 2 may hide 0 ([0 * 3 + 2] = 1): read with rows of 2, [1 * 2 + 0]
  // would be that 1.
  scene.may_hide = {0, 0, 1, 0, 0, 0, 0, 0, 0};
  VisibilityInputs inputs = scene.inputs(0.005);
  inputs.may_hide_stride = 3;
  std::vector<double> v;
  softVisibility(inputs, &v);
  EXPECT_EQ(v[0], 1.0);
  EXPECT_EQ(v[1], 1.0) << "0 may not hide 1 in this table";
  scene.may_hide = {0, 0, 0, 1, 0, 0, 0, 0, 0};  // 0 may hide 1
  inputs = scene.inputs(0.005);
  inputs.may_hide_stride = 3;
  softVisibility(inputs, &v);
  EXPECT_NEAR(v[1], 0.5, 1e-6);
}

// accumulateVisibilityGradient's derivatives of sum_p g_p v_p equal central differences in every
// mean, covariance entry and depth of a random scene of overlapping Gaussians.
TEST(Visibility, GradientMatchesCentralDifferences) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> position(-6.0, 6.0), spread(2.0, 9.0), tilt(-1.5, 1.5);
  std::uniform_real_distribution<double> depth(0.38, 0.42), weight(-1.0, 1.0);
  constexpr int kCount = 7;
  struct Raw {
    double x, y, xx, xy, yy, z;
  };
  std::vector<Raw> raw;
  for (int p = 0; p < kCount; ++p) {
    raw.push_back({position(rng), position(rng), spread(rng), tilt(rng), spread(rng), depth(rng)});
  }
  std::vector<double> g;
  for (int p = 0; p < kCount; ++p) g.push_back(weight(rng));
  std::vector<char> may_hide(kCount * kCount, 1);
  for (int p = 0; p < kCount; ++p) may_hide[p * kCount + p] = 0;
  may_hide[0 * kCount + 1] = may_hide[1 * kCount + 0] = 0;  // one surface
  constexpr double kScale = 0.01;
  auto evaluate = [&](const std::vector<Raw>& scene, std::vector<ProjectedGradient>* gradient) {
    Scene s;
    for (const Raw& r : scene) {
      s.terms.push_back(term(r.x, r.y, r.xx, r.xy, r.yy));
      s.depths.push_back(r.z);
    }
    s.valid.assign(kCount, 1);
    s.may_hide = may_hide;
    std::vector<double> v;
    std::vector<Occlusion> pairs;
    softVisibility(s.inputs(kScale), &v, &pairs);
    double sum = 0.0;
    for (int p = 0; p < kCount; ++p) sum += g[p] * v[p];
    if (gradient) {
      gradient->assign(kCount, ProjectedGradient::Zero());
      accumulateVisibilityGradient(s.inputs(kScale), v, pairs, g, gradient);
    }
    return sum;
  };
  std::vector<ProjectedGradient> analytic;
  evaluate(raw, &analytic);
  int checked = 0;
  for (int p = 0; p < kCount; ++p) {
    for (int k = 0; k < 6; ++k) {
      const double step = k == 5 ? 1e-6 : 1e-5;
      auto shifted = [&](double by) {
        std::vector<Raw> scene = raw;
        double* entries[6] = {&scene[p].x,  &scene[p].y,  &scene[p].xx,
                              &scene[p].xy, &scene[p].yy, &scene[p].z};
        *entries[k] += by;
        return evaluate(scene, nullptr);
      };
      const double numeric = (shifted(step) - shifted(-step)) / (2.0 * step);
      EXPECT_NEAR(analytic[p][k], numeric, 1e-5 + 1e-4 * std::fabs(numeric))
          << "Gaussian " << p << " entry " << k;
      ++checked;
    }
  }
  EXPECT_EQ(checked, kCount * 6);
}

}  // namespace sag_hand_tracker
