// Tests of the image-to-SoG segmentation: quad-tree, background plate, shadows, sleeve, skin gate.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "sag_hand_tracker/energy/colour.h"
#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"
#include "test_support/segmentation_test_images.h"
// detail::ColourIntegral
#include "../../src/segmentation/segmentation_internal.h"

using namespace sag_hand_tracker;

namespace {

cv::Mat uniform(int width, int height, cv::Scalar rgb) {
  return cv::Mat(height, width, CV_8UC3, rgb);
}

SegmentationParams noneParams() {
  SegmentationParams p;
  p.mode = SegmentationMode::kNone;
  return p;
}

// How many leaves cover each pixel.
cv::Mat coverage(int width, int height, const std::vector<QuadtreeLeaf>& leaves) {
  cv::Mat count = cv::Mat::zeros(height, width, CV_32S);
  for (const QuadtreeLeaf& l : leaves) count(cv::Rect(l.x, l.y, l.width, l.height)) += 1;
  return count;
}

// Naive quad-tree: the same rules, statistics by looping over the pixels.
void referenceVisit(const cv::Mat& img, const QuadtreeParams& p, int x, int y, int s,
                    std::vector<QuadtreeLeaf>& out) {
  if (x >= img.cols || y >= img.rows) return;
  const int x1 = std::min(x + s, img.cols), y1 = std::min(y + s, img.rows);
  double sum[3] = {0, 0, 0}, sum_sq[3] = {0, 0, 0};
  for (int yy = y; yy < y1; ++yy) {
    for (int xx = x; xx < x1; ++xx) {
      const cv::Vec3b v = img.at<cv::Vec3b>(yy, xx);
      for (int k = 0; k < 3; ++k) {
        sum[k] += v[k];
        sum_sq[k] += double(v[k]) * v[k];
      }
    }
  }
  const double n = double(x1 - x) * (y1 - y);
  bool split = s > p.min_leaf_size && (x1 - x < s || y1 - y < s);
  for (int k = 0; k < 3 && s > p.min_leaf_size; ++k) {
    const double mean = sum[k] / n;
    if (sum_sq[k] / n - mean * mean > p.max_colour_std * p.max_colour_std) split = true;
  }
  if (split) {
    const int h = s / 2;
    referenceVisit(img, p, x, y, h, out);
    referenceVisit(img, p, x + h, y, h, out);
    referenceVisit(img, p, x, y + h, h, out);
    referenceVisit(img, p, x + h, y + h, h, out);
    return;
  }
  QuadtreeLeaf leaf;
  leaf.x = x;
  leaf.y = y;
  leaf.width = x1 - x;
  leaf.height = y1 - y;
  leaf.rgb = Eigen::Vector3d(sum[0] / n, sum[1] / n, sum[2] / n);
  out.push_back(leaf);
}

std::vector<QuadtreeLeaf> referenceLeaves(const cv::Mat& img, const QuadtreeParams& p) {
  std::vector<QuadtreeLeaf> out;
  for (int y = 0; y < img.rows; y += p.max_leaf_size) {
    for (int x = 0; x < img.cols; x += p.max_leaf_size) {
      referenceVisit(img, p, x, y, p.max_leaf_size, out);
    }
  }
  return out;
}

bool leafOrder(const QuadtreeLeaf& a, const QuadtreeLeaf& b) {
  return std::tie(a.y, a.x) < std::tie(b.y, b.x);
}

// Blocky random image: random rectangles of random colours plus noise.
cv::Mat blockyImage(int width, int height, unsigned seed) {
  cv::RNG rng(seed);
  cv::Mat img(height, width, CV_8UC3, cv::Scalar(120, 130, 140));
  for (int i = 0; i < 25; ++i) {
    const int x = rng.uniform(0, width), y = rng.uniform(0, height);
    const int w = rng.uniform(1, width / 2), h = rng.uniform(1, height / 2);
    cv::rectangle(img, cv::Rect(x, y, w, h),
                  cv::Scalar(rng.uniform(0, 256), rng.uniform(0, 256), rng.uniform(0, 256)),
                  cv::FILLED);
  }
  cv::Mat noise(img.size(), CV_8UC3);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 6);
  img += noise;
  return img;
}

// Fraction of the leaves' area inside mask, and fraction of mask covered by leaves.
struct Overlap {
  double precision = 0.0;
  double recall = 0.0;
  int leaf_area = 0;
};
Overlap overlapWith(const cv::Mat& mask, const std::vector<QuadtreeLeaf>& leaves) {
  cv::Mat covered = cv::Mat::zeros(mask.size(), CV_8UC1);
  for (const QuadtreeLeaf& l : leaves) covered(cv::Rect(l.x, l.y, l.width, l.height)).setTo(255);
  Overlap o;
  o.leaf_area = cv::countNonZero(covered);
  const int inside = cv::countNonZero(covered & mask);
  o.precision = o.leaf_area > 0 ? double(inside) / o.leaf_area : 0.0;
  o.recall = double(inside) / std::max(1, cv::countNonZero(mask));
  return o;
}

cv::Mat dilate(const cv::Mat& mask, int radius) {
  cv::Mat out;
  cv::dilate(mask, out,
             cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * radius + 1, 2 * radius + 1)));
  return out;
}

ImageSegmenter learnedSegmenter(SegmentationMode mode,
                                SegmentationParams p = SegmentationParams()) {
  p.mode = mode;
  ImageSegmenter segmenter(p);
  for (unsigned seed = 0; seed < 10; ++seed) {
    segmenter.addBackgroundFrame(sag_test::backgroundFrame(seed));
  }
  return segmenter;
}

template <typename F>
std::string inputErrorMessage(F f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "<no InputError>";
}

}  // namespace

// ---- quad-tree ----------------------------------------------------------------------------------

TEST(Segment, UniformImageGivesRootGridOfLeaves) {
  // 320 x 240 with 32-pixel roots: 10 x 7 full roots, and the last 16 rows are clipped roots,
  // split into 16 x 16 leaves (20 of them).
  const cv::Mat img = uniform(320, 240, cv::Scalar(200, 120, 40));
  std::vector<QuadtreeLeaf> leaves;
  const ImageSoG sog = ImageSegmenter(noneParams()).segment(img, &leaves);
  EXPECT_EQ(sog.width, 320);
  EXPECT_EQ(sog.height, 240);
  ASSERT_EQ(sog.gaussians.size(), 90u);
  ASSERT_EQ(leaves.size(), 90u);
  const double factor = QuadtreeParams().sigma_per_leaf_size;
  const Hsv expected = rgbToHsv(200, 120, 40);
  int big = 0, small = 0;
  for (std::size_t i = 0; i < leaves.size(); ++i) {
    const QuadtreeLeaf& l = leaves[i];
    const ImageGaussian& g = sog.gaussians[i];
    ASSERT_EQ(l.width, l.height);
    if (l.width == 32) {
      ++big;
      EXPECT_LT(l.y, 224);
      EXPECT_EQ(l.x % 32, 0);
      EXPECT_EQ(l.y % 32, 0);
    } else {
      ++small;
      EXPECT_EQ(l.width, 16);
      EXPECT_EQ(l.y, 224);
    }
    // Mean at the leaf centre with pixel centres on integers; sigma proportional to the size.
    EXPECT_DOUBLE_EQ(g.mean.x(), l.x + (l.width - 1) / 2.0);
    EXPECT_DOUBLE_EQ(g.mean.y(), l.y + (l.height - 1) / 2.0);
    EXPECT_DOUBLE_EQ(g.sigma, factor * l.width);
    EXPECT_NEAR((g.hsv - expected).norm(), 0.0, 1e-9);
  }
  EXPECT_EQ(big, 70);
  EXPECT_EQ(small, 20);
  EXPECT_NEAR(sog.gaussians[0].mean.x(), 15.5, 1e-12);
  EXPECT_NEAR(sog.gaussians[0].sigma, 32.0 / std::sqrt(2.0 * M_PI), 1e-12);
}

TEST(Segment, AlignedSquareIsOneLeaf) {
  cv::Mat img = uniform(128, 128, cv::Scalar(200, 30, 30));
  img(cv::Rect(32, 32, 32, 32)).setTo(cv::Scalar(30, 200, 60));
  std::vector<QuadtreeLeaf> leaves;
  const ImageSoG sog = ImageSegmenter(noneParams()).segment(img, &leaves);
  ASSERT_EQ(sog.gaussians.size(), 16u);
  int green = 0;
  for (std::size_t i = 0; i < leaves.size(); ++i) {
    EXPECT_EQ(leaves[i].width, 32);
    if (leaves[i].rgb.isApprox(Eigen::Vector3d(30, 200, 60))) {
      ++green;
      EXPECT_EQ(leaves[i].x, 32);
      EXPECT_EQ(leaves[i].y, 32);
      EXPECT_DOUBLE_EQ(sog.gaussians[i].mean.x(), 47.5);
      EXPECT_NEAR(sog.gaussians[i].hsv[0], rgbToHsv(30, 200, 60)[0], 1e-9);
    } else {
      EXPECT_TRUE(leaves[i].rgb.isApprox(Eigen::Vector3d(200, 30, 30)));
    }
  }
  EXPECT_EQ(green, 1);
}

TEST(Segment, UnalignedRectangleHasSmallLeavesOnlyAtItsEdges) {
  const Eigen::Vector3d grey(128, 128, 128), blue(40, 60, 200);
  cv::Mat img = uniform(64, 64, cv::Scalar(128, 128, 128));
  const cv::Rect rect(13, 21, 31, 29);  // columns 13..43, rows 21..49
  img(rect).setTo(cv::Scalar(40, 60, 200));
  SegmentationParams p = noneParams();
  p.quadtree.min_leaf_size = 2;
  std::vector<QuadtreeLeaf> leaves;
  const ImageSoG sog = ImageSegmenter(p).segment(img, &leaves);
  ASSERT_EQ(sog.gaussians.size(), leaves.size());
  // The leaves tile the image.
  const cv::Mat count = coverage(64, 64, leaves);
  double min_count = 0, max_count = 0;
  cv::minMaxLoc(count, &min_count, &max_count);
  EXPECT_EQ(min_count, 1.0);
  EXPECT_EQ(max_count, 1.0);
  int mixed = 0, blue_area = 0;
  for (const QuadtreeLeaf& l : leaves) {
    const cv::Rect r(l.x, l.y, l.width, l.height);
    const int inside = (r & rect).area();
    if (inside == 0) {
      EXPECT_TRUE(l.rgb.isApprox(grey)) << l.x << "," << l.y;
    } else if (inside == r.area()) {
      EXPECT_TRUE(l.rgb.isApprox(blue)) << l.x << "," << l.y;
      blue_area += inside;
    } else {
      // A leaf straddling the edge is a smallest leaf; its colour is the area-weighted mix.
      ++mixed;
      EXPECT_EQ(l.width, 2);
      const double a = double(inside) / r.area();
      EXPECT_NEAR((l.rgb - (a * blue + (1 - a) * grey)).norm(), 0.0, 1e-9);
    }
  }
  // The odd left and top edges cut 2x2 leaves; the right (43 | 44) and bottom (49 | 50) edges fall
  // between leaves. Rows 20..49 -> 15 leaves along the left edge, columns 12..43 -> 16 along the
  // top one, sharing the corner leaf.
  EXPECT_EQ(mixed, 15 + 16 - 1);
  EXPECT_GT(blue_area, 0);
  // Deep inside the rectangle and far outside it the leaves are large.
  for (const QuadtreeLeaf& l : leaves) {
    if (cv::Rect(l.x, l.y, l.width, l.height).contains(cv::Point(30, 36))) {
      EXPECT_GE(l.width, 8);
    }
    if (cv::Rect(l.x, l.y, l.width, l.height).contains(cv::Point(60, 4))) {
      EXPECT_GE(l.width, 16);
    }
  }
}

TEST(Segment, MatchesBruteForceReference) {
  struct Case {
    int width, height, min_leaf, max_leaf;
    double max_std;
  };
  const Case cases[] = {{100, 70, 2, 32, 12.0},
                        {101, 71, 1, 16, 8.0},
                        {320, 240, 4, 32, 12.0},
                        {97, 130, 4, 64, 20.0},
                        {64, 48, 8, 8, 5.0}};
  unsigned seed = 3;
  for (const Case& c : cases) {
    const cv::Mat img = blockyImage(c.width, c.height, seed++);
    QuadtreeParams p;
    p.min_leaf_size = c.min_leaf;
    p.max_leaf_size = c.max_leaf;
    p.max_colour_std = c.max_std;
    std::vector<QuadtreeLeaf> fast;
    const ImageSoG sog = quadtreeSegment(img, p, &fast);
    std::vector<QuadtreeLeaf> slow = referenceLeaves(img, p);
    ASSERT_EQ(fast.size(), slow.size()) << c.width << "x" << c.height;
    ASSERT_EQ(sog.gaussians.size(), fast.size());
    // Clipped leaves at the border get sigma from sqrt(w h).
    for (std::size_t i = 0; i < fast.size(); ++i) {
      EXPECT_NEAR(sog.gaussians[i].sigma,
                  p.sigma_per_leaf_size * std::sqrt(double(fast[i].width) * fast[i].height), 1e-12);
    }
    std::sort(fast.begin(), fast.end(), leafOrder);
    std::sort(slow.begin(), slow.end(), leafOrder);
    for (std::size_t i = 0; i < fast.size(); ++i) {
      ASSERT_EQ(fast[i].x, slow[i].x);
      ASSERT_EQ(fast[i].y, slow[i].y);
      ASSERT_EQ(fast[i].width, slow[i].width);
      ASSERT_EQ(fast[i].height, slow[i].height);
      EXPECT_NEAR((fast[i].rgb - slow[i].rgb).norm(), 0.0, 1e-9);
    }
  }
}

TEST(Segment, CameraNoiseDoesNotSplitButEdgesDo) {
  cv::Mat img = uniform(128, 96, cv::Scalar(90, 140, 60));
  cv::Mat noise(img.size(), CV_32FC3);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 3.0);
  cv::Mat noisy;
  img.convertTo(noisy, CV_32FC3);
  noisy += noise;
  noisy.convertTo(noisy, CV_8UC3);
  EXPECT_EQ(ImageSegmenter(noneParams()).segment(noisy).gaussians.size(), 12u);
  // A line of a different colour splits the squares it crosses.
  cv::line(noisy, cv::Point(0, 50), cv::Point(127, 50), cv::Scalar(220, 220, 220), 1);
  EXPECT_GT(ImageSegmenter(noneParams()).segment(noisy).gaussians.size(), 12u + 4u * 16u);
}

TEST(Segment, ColourThresholdControlsLeafCount) {
  // A horizontal colour ramp: a stricter threshold needs smaller leaves.
  cv::Mat img(96, 128, CV_8UC3);
  for (int x = 0; x < 128; ++x) img.col(x).setTo(cv::Scalar(2 * x, 255 - 2 * x, 100));
  // The standard deviation of a ramp of slope 2 over s columns is 2 sqrt((s^2 - 1) / 12):
  // 18.5 (s = 32), 9.2 (16), 4.6 (8), 2.2 (4).
  const std::pair<double, std::size_t> expected[] = {
      {40.0, 12}, {15.0, 48}, {7.0, 192}, {3.0, 768}, {1.0, 768}};  // min_leaf_size 4 stops it
  for (const auto& [threshold, count] : expected) {
    SegmentationParams p = noneParams();
    p.quadtree.max_colour_std = threshold;
    EXPECT_EQ(ImageSegmenter(p).segment(img).gaussians.size(), count) << "threshold " << threshold;
  }
}

TEST(Segment, RealisticSceneGaussianCount) {
  sag_test::SceneOptions o;
  o.hand = o.sleeve = o.shadow = true;
  const cv::Mat img = sag_test::scene(o);
  const std::size_t with_hand = ImageSegmenter(noneParams()).segment(img).gaussians.size();
  const std::size_t background =
      ImageSegmenter(noneParams()).segment(sag_test::backgroundFrame(1)).gaussians.size();
  std::printf("[ info ] realistic 320x240 scene, mode none: %zu Gaussians (%zu without the hand)\n",
              with_hand, background);
  // The cluttered desk (poster, keyboard, book, mug) has ~1000 leaves, hand + sleeve + shadow
  // add ~500: the order of magnitude of the paper (~500 per image), far below the 4800 leaves of
  // the minimum size.
  EXPECT_GT(with_hand, 900u);
  EXPECT_LT(with_hand, 2500u);
  EXPECT_GT(with_hand, background + 250);
  // The same scene at 640 x 480 needs more leaves, but fewer than 4 times as many (uniform
  // regions get the largest leaves).
  o.width = 640;
  o.height = 480;
  const std::size_t large =
      ImageSegmenter(noneParams()).segment(sag_test::scene(o)).gaussians.size();
  EXPECT_GT(large, with_hand);
  EXPECT_LT(large, 4 * with_hand);
}

TEST(Segment, RejectsBadImages) {
  ImageSegmenter segmenter(noneParams());
  EXPECT_NE(inputErrorMessage([&] { segmenter.segment(cv::Mat()); }).find("empty"),
            std::string::npos);
  const std::string grey =
      inputErrorMessage([&] { segmenter.segment(cv::Mat(24, 32, CV_8UC1, cv::Scalar(0))); });
  EXPECT_NE(grey.find("CV_8UC1"), std::string::npos) << grey;
  EXPECT_NE(grey.find("CV_8UC3"), std::string::npos) << grey;
  for (int type : {CV_8UC4, CV_16UC3, CV_32FC3, CV_8SC3}) {
    const cv::Mat bad(24, 32, type, cv::Scalar::all(0));
    const std::string message = inputErrorMessage([&] { segmenter.segment(bad); });
    EXPECT_NE(message.find(cv::typeToString(type)), std::string::npos) << message;
    EXPECT_THROW(segmenter.foregroundMask(bad), InputError);
    EXPECT_THROW(segmenter.addBackgroundFrame(bad), InputError);
    EXPECT_THROW(quadtreeSegment(bad, QuadtreeParams()), InputError);
  }
}

TEST(Segment, RejectsBadParameters) {
  auto message = [](auto change) {
    SegmentationParams p;
    change(p);
    return inputErrorMessage([&] { ImageSegmenter segmenter(p); });
  };
  EXPECT_NE(
      message([](SegmentationParams& p) { p.quadtree.min_leaf_size = 3; }).find("min_leaf_size"),
      std::string::npos);
  EXPECT_NE(
      message([](SegmentationParams& p) { p.quadtree.max_leaf_size = 256; }).find("max_leaf_size"),
      std::string::npos);
  EXPECT_NE(
      message([](SegmentationParams& p) { p.quadtree.max_leaf_size = 2; }).find("max_leaf_size"),
      std::string::npos);
  EXPECT_NE(message([](SegmentationParams& p) { p.cell_size = 6; }).find("cell_size"),
            std::string::npos);
  EXPECT_NE(message([](SegmentationParams& p) { p.background.frames = 0; }).find("frames"),
            std::string::npos);
  EXPECT_NE(message([](SegmentationParams& p) { p.skin.hue_max_deg = -30; }).find("hue"),
            std::string::npos);
  EXPECT_EQ(message([](SegmentationParams&) {}), "<no InputError>");
  ImageSegmenter segmenter;
  SegmentationParams bad;
  bad.quadtree.sigma_per_leaf_size = 0.0;
  EXPECT_THROW(segmenter.setParams(bad), InputError);
  EXPECT_EQ(segmenter.params().quadtree.sigma_per_leaf_size, QuadtreeParams().sigma_per_leaf_size);
}

TEST(Segment, ModeNamesRoundTrip) {
  for (SegmentationMode mode : {SegmentationMode::kNone, SegmentationMode::kPlate,
                                SegmentationMode::kSkin, SegmentationMode::kPlateAndSkin}) {
    EXPECT_EQ(parseSegmentationMode(toString(mode)), mode);
  }
  EXPECT_NE(inputErrorMessage([] { parseSegmentationMode("skinn"); }).find("skinn"),
            std::string::npos);
}

// ---- background plate ---------------------------------------------------------------------------

TEST(Background, ReadyAfterConfiguredFramesAndFallsBackToSkinBefore) {
  SegmentationParams p;
  p.mode = SegmentationMode::kPlate;
  p.background.frames = 3;
  ImageSegmenter segmenter(p);
  EXPECT_FALSE(segmenter.backgroundReady());
  EXPECT_EQ(segmenter.effectiveMode(), SegmentationMode::kSkin);
  // Before the plate is ready the skin gate applies: exactly what mode skin gives, the hand and
  // not the desk. (The gate is not perfect: the cells where the red mug's rim blends with the grey
  // desk have skin hue and saturation.)
  sag_test::SceneOptions o;
  o.hand = true;
  const cv::Mat frame = sag_test::scene(o);
  SegmentationParams skin = p;
  skin.mode = SegmentationMode::kSkin;
  std::vector<QuadtreeLeaf> fallback, explicit_skin;
  segmenter.segment(frame, &fallback);
  ImageSegmenter(skin).segment(frame, &explicit_skin);
  ASSERT_EQ(fallback.size(), explicit_skin.size());
  for (std::size_t i = 0; i < fallback.size(); ++i) {
    EXPECT_EQ(fallback[i].x, explicit_skin[i].x);
    EXPECT_EQ(fallback[i].y, explicit_skin[i].y);
  }
  const Overlap overlap = overlapWith(sag_test::handMask(o), fallback);
  EXPECT_GT(overlap.recall, 0.9);
  EXPECT_GT(overlap.precision, 0.8);
  segmenter.addBackgroundFrame(sag_test::backgroundFrame(0));
  segmenter.addBackgroundFrame(sag_test::backgroundFrame(1));
  EXPECT_FALSE(segmenter.backgroundReady());
  segmenter.addBackgroundFrame(sag_test::backgroundFrame(2));
  EXPECT_TRUE(segmenter.backgroundReady());
  EXPECT_EQ(segmenter.backgroundFrameCount(), 3);
  EXPECT_EQ(segmenter.effectiveMode(), SegmentationMode::kPlate);
  segmenter.resetBackground();
  EXPECT_FALSE(segmenter.backgroundReady());
  EXPECT_EQ(segmenter.backgroundFrameCount(), 0);
}

TEST(Background, RemovesEverythingOnBackgroundOnlyFrames) {
  const ImageSegmenter segmenter = learnedSegmenter(SegmentationMode::kPlate);
  ASSERT_TRUE(segmenter.backgroundReady());
  for (unsigned seed = 100; seed < 105; ++seed) {
    const cv::Mat frame = sag_test::backgroundFrame(seed);  // new camera noise
    EXPECT_EQ(segmenter.segment(frame).gaussians.size(), 0u) << "seed " << seed;
    EXPECT_EQ(cv::countNonZero(segmenter.foregroundMask(frame)), 0);
  }
  // The same frames without a plate (mode none) are full of leaves.
  EXPECT_GT(ImageSegmenter(noneParams()).segment(sag_test::backgroundFrame(100)).gaussians.size(),
            500u);
}

TEST(Background, KeepsSkinColouredHand) {
  const ImageSegmenter segmenter = learnedSegmenter(SegmentationMode::kPlate);
  sag_test::SceneOptions o;
  o.hand = true;
  o.seed = 42;
  std::vector<QuadtreeLeaf> leaves;
  const ImageSoG sog = segmenter.segment(sag_test::scene(o), &leaves);
  const cv::Mat hand = sag_test::handMask(o);
  const Overlap overlap = overlapWith(hand, leaves);
  EXPECT_GT(sog.gaussians.size(), 100u);
  EXPECT_LT(sog.gaussians.size(), 500u);
  EXPECT_GT(overlap.recall, 0.9);  // the silhouette is accurate to a cell (4 px)
  // Every leaf lies on the hand or within a cell of its outline.
  EXPECT_GT(overlapWith(dilate(hand, 4), leaves).precision, 0.999);
  // Leaves on the hand have skin colour; the others are cells on the outline that hold a part of
  // the hand (their mean differs from the plate) and are at most a fifth of the leaf area.
  EXPECT_GT(overlap.precision, 0.8);
  std::printf("[ info ] hand on desk, mode plate: %zu Gaussians, recall %.3f, precision %.3f\n",
              sog.gaussians.size(), overlap.recall, overlap.precision);
  int inside = 0;
  for (const QuadtreeLeaf& l : leaves) {
    if (cv::countNonZero(hand(cv::Rect(l.x, l.y, l.width, l.height))) < l.width * l.height)
      continue;
    ++inside;
    EXPECT_TRUE(isSkinColour(l.rgb, SkinParams())) << l.rgb.transpose();
  }
  EXPECT_GT(inside, 50);
}

TEST(Background, RemovesShadowOfHandAndArmOnDesk) {
  // Shadow only (hand and arm out of view): the darkened desk must not become foreground.
  SegmentationParams p;
  // Without the dark/sleeve rule, so that only the shadow test can remove the shadow.
  p.background.dark_max_value = 0.0;
  p.background.sleeve_max_value = 0.0;
  const ImageSegmenter segmenter = learnedSegmenter(SegmentationMode::kPlate, p);
  for (double factor : {0.35, 0.55, 0.75, 0.9}) {
    sag_test::SceneOptions o;
    o.shadow = true;
    o.shadow_factor = factor;
    o.seed = 7;
    EXPECT_EQ(segmenter.segment(sag_test::scene(o)).gaussians.size(), 0u) << factor;
  }
  // Control: without the shadow test the same shadow is foreground.
  p.background.shadow_chroma_tolerance = 0.0;
  const ImageSegmenter no_shadow_test = learnedSegmenter(SegmentationMode::kPlate, p);
  sag_test::SceneOptions o;
  o.shadow = true;
  EXPECT_GT(no_shadow_test.segment(sag_test::scene(o)).gaussians.size(), 50u);
}

TEST(Background, RemovesShadowOnColouredSurface) {
  // A saturated blue table: a shadow on it is neither dark nor grey, only the chromaticity test
  // identifies it. A skin-coloured patch of the same brightness is kept.
  const cv::Mat table = uniform(160, 120, cv::Scalar(60, 110, 200));
  SegmentationParams p;
  p.background.frames = 1;
  ImageSegmenter segmenter(p);
  segmenter.addBackgroundFrame(table);
  cv::Mat frame = table.clone();
  frame(cv::Rect(0, 0, 80, 120)) *= 0.6;  // (36, 66, 120): value 0.47, saturation 0.7
  EXPECT_EQ(segmenter.segment(frame).gaussians.size(), 0u);
  frame(cv::Rect(100, 40, 40, 40)).setTo(cv::Scalar(150, 110, 90));
  std::vector<QuadtreeLeaf> leaves;
  segmenter.segment(frame, &leaves);
  cv::Mat patch = cv::Mat::zeros(120, 160, CV_8UC1);
  patch(cv::Rect(100, 40, 40, 40)).setTo(255);
  const Overlap overlap = overlapWith(patch, leaves);
  EXPECT_DOUBLE_EQ(overlap.precision, 1.0);
  EXPECT_DOUBLE_EQ(overlap.recall, 1.0);
  // A shadow darker than shadow_min_ratio is not explained as a shadow any more.
  cv::Mat deep = table.clone();
  deep(cv::Rect(0, 0, 80, 120)) *= 0.15;
  SegmentationParams keep_dark = p;
  keep_dark.background.dark_max_value = 0.0;
  keep_dark.background.sleeve_max_value = 0.0;
  segmenter.setParams(keep_dark);
  EXPECT_GT(segmenter.segment(deep).gaussians.size(), 0u);
}

TEST(Background, RemovesBlackSleeve) {
  const ImageSegmenter segmenter = learnedSegmenter(SegmentationMode::kPlate);
  sag_test::SceneOptions o;
  o.sleeve = true;
  o.shadow = true;
  EXPECT_EQ(segmenter.segment(sag_test::scene(o)).gaussians.size(), 0u);
  // Control: the sleeve differs from the plate, only the dark/unsaturated rule removes it.
  SegmentationParams p;
  p.background.dark_max_value = 0.0;
  p.background.sleeve_max_value = 0.0;
  const ImageSegmenter without_rule = learnedSegmenter(SegmentationMode::kPlate, p);
  o.shadow = false;
  std::vector<QuadtreeLeaf> leaves;
  without_rule.segment(sag_test::scene(o), &leaves);
  EXPECT_GT(overlapWith(sag_test::sleeveMask(o), leaves).recall, 0.8);
}

// The sleeve is the tracker's forearm cue (ImageSoG::arm_cells): where it meets the hand, i.e.
// its part within RoomCueParams::sleeve_band_cells of the hand, not its middle (the wrist prior,
// EnergyParams::wrist_weight, reads the wrist from it). The stateful per-frame call that the
// pipeline and the segmentation nodelet use must report it like segment() does.
TEST(Background, ReportsWhereTheSleeveMeetsTheHandAsForearmEvidenceInEverySegmentCall) {
  sag_test::SceneOptions o;
  o.hand = o.sleeve = true;
  const cv::Mat frame = sag_test::scene(o);
  const SegmentationParams params;
  const cv::Mat hand = sag_test::handMask(o);
  const cv::Mat sleeve = sag_test::sleeveMask(o) & ~hand;  // the part the hand does not hide
  cv::Mat from_hand;
  cv::distanceTransform(255 - hand, from_hand, cv::DIST_L2, 3);
  const double band = params.room.sleeve_band_cells * params.cell_size;
  cv::Mat sleeve_points, band_points;
  cv::findNonZero(sleeve, sleeve_points);
  cv::findNonZero(sleeve & (from_hand <= band), band_points);
  ASSERT_GT(band_points.total(), 20u);
  const cv::Scalar sleeve_centre = cv::mean(sleeve_points), band_centre = cv::mean(band_points);
  const Eigen::Vector2d band_at(band_centre[0], band_centre[1]);
  const Eigen::Vector2d sleeve_at(sleeve_centre[0], sleeve_centre[1]);
  ASSERT_GT((band_at - sleeve_at).norm(), 20.0);  // the test tells the two apart
  ImageSegmenter segmenter = learnedSegmenter(SegmentationMode::kPlate);
  const ImageSoG once = segmenter.segment(frame);
  const ImageSoG per_frame = segmenter.segmentFrame(frame);
  for (const ImageSoG* sog : {&once, &per_frame}) {
    EXPECT_GT(sog->arm_cells, 10);
    // Cells, not pixels: within a cell and a half of the band's own centroid.
    EXPECT_LT((sog->arm_centroid - band_at).norm(), 1.5 * params.cell_size)
        << "at " << sog->arm_centroid.transpose() << ", the band at " << band_at.transpose()
        << ", the whole sleeve at " << sleeve_at.transpose();
    // The cells themselves (the silhouette scores' occluded pixels): one leaf per cell, on the
    // sleeve within the band, averaging to the centroid.
    ASSERT_EQ(sog->arm_gaussians.size(), static_cast<size_t>(sog->arm_cells));
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    int on_the_band = 0;
    for (const ImageGaussian& g : sog->arm_gaussians) {
      sum += g.mean;
      EXPECT_NEAR(g.sigma * std::sqrt(2.0 * M_PI), params.cell_size, 1e-9);
      const cv::Point at(static_cast<int>(g.mean.x()), static_cast<int>(g.mean.y()));
      on_the_band += sag_test::sleeveMask(o).at<unsigned char>(at) != 0 &&
                     from_hand.at<float>(at) <= band + params.cell_size;
    }
    EXPECT_LT((sum / sog->arm_cells - sog->arm_centroid).norm(), 1e-9);
    EXPECT_GE(on_the_band, 0.9 * sog->arm_cells);
  }
  EXPECT_EQ(per_frame.arm_cells, once.arm_cells);
  // Without the sleeve there is no evidence.
  o.sleeve = false;
  const ImageSoG bare = segmenter.segmentFrame(sag_test::scene(o));
  EXPECT_EQ(bare.arm_cells, 0);
  EXPECT_TRUE(bare.arm_gaussians.empty());
}

TEST(Background, FullSceneKeepsOnlyTheHand) {
  sag_test::SceneOptions o;
  o.hand = o.sleeve = o.shadow = true;
  o.seed = 11;
  const cv::Mat hand = sag_test::handMask(o);
  for (SegmentationMode mode : {SegmentationMode::kPlate, SegmentationMode::kPlateAndSkin}) {
    const ImageSegmenter segmenter = learnedSegmenter(mode);
    std::vector<QuadtreeLeaf> leaves;
    const ImageSoG sog = segmenter.segment(sag_test::scene(o), &leaves);
    EXPECT_GT(sog.gaussians.size(), 100u) << toString(mode);
    EXPECT_LT(sog.gaussians.size(), 500u) << toString(mode);
    EXPECT_GT(overlapWith(hand, leaves).recall, 0.9) << toString(mode);
    EXPECT_GT(overlapWith(dilate(hand, 4), leaves).precision, 0.999) << toString(mode);
    std::printf("[ info ] hand + sleeve + shadow, mode %s: %zu Gaussians\n", toString(mode),
                sog.gaussians.size());
  }
}

TEST(Background, ForeignObjectsNeedTheSkinGate) {
  // A blue cup put on the desk after the plate was learned is foreground for the plate alone;
  // plate_and_skin removes it and keeps the hand.
  sag_test::SceneOptions o;
  o.hand = true;
  cv::Mat frame = sag_test::scene(o);
  cv::circle(frame, cv::Point(270, 120), 16, cv::Scalar(30, 70, 190), cv::FILLED);
  cv::Mat cup = cv::Mat::zeros(frame.size(), CV_8UC1);
  cv::circle(cup, cv::Point(270, 120), 16, cv::Scalar(255), cv::FILLED);
  std::vector<QuadtreeLeaf> leaves;
  learnedSegmenter(SegmentationMode::kPlate).segment(frame, &leaves);
  EXPECT_GT(overlapWith(cup, leaves).recall, 0.8);
  learnedSegmenter(SegmentationMode::kPlateAndSkin).segment(frame, &leaves);
  EXPECT_EQ(overlapWith(cup, leaves).recall, 0.0);
  EXPECT_GT(overlapWith(sag_test::handMask(o), leaves).recall, 0.9);
}

TEST(Background, LearnsPerCellSpread) {
  // A flickering region (a screen) alternates between two greys 40 apart while the plate is
  // learned: its tolerance widens (3 x spread 20 = 60), the static part's stays at the floor.
  cv::Mat a = uniform(64, 64, cv::Scalar(100, 100, 100));
  cv::Mat b = a.clone();
  b(cv::Rect(0, 0, 32, 64)).setTo(cv::Scalar(140, 140, 140));
  SegmentationParams p;
  p.background.frames = 10;
  p.background.dark_max_value = 0.0;
  p.background.sleeve_max_value = 0.0;
  ImageSegmenter segmenter(p);
  for (int i = 0; i < 10; ++i) segmenter.addBackgroundFrame(i % 2 ? a : b);
  const cv::Mat spread = segmenter.backgroundPlate().spread();
  EXPECT_NEAR(spread.at<cv::Vec3f>(0, 0)[0], 20.0f, 1e-3f);
  EXPECT_NEAR(spread.at<cv::Vec3f>(0, 15)[1], 0.0f, 1e-3f);
  EXPECT_NEAR(segmenter.backgroundPlate().mean().at<cv::Vec3f>(5, 3)[2], 120.0f, 1e-3f);
  // +30 (brighter, so not a shadow) on both halves: background where it flickered, foreground on
  // the static half.
  cv::Mat test = uniform(64, 64, cv::Scalar(150, 150, 150));
  test(cv::Rect(32, 0, 32, 64)).setTo(cv::Scalar(130, 130, 130));
  std::vector<QuadtreeLeaf> leaves;
  segmenter.segment(test, &leaves);
  cv::Mat right = cv::Mat::zeros(64, 64, CV_8UC1);
  right(cv::Rect(32, 0, 32, 64)).setTo(255);
  const Overlap overlap = overlapWith(right, leaves);
  EXPECT_DOUBLE_EQ(overlap.precision, 1.0);
  EXPECT_DOUBLE_EQ(overlap.recall, 1.0);
}

TEST(Background, RemovesIsolatedNoiseCells) {
  cv::Mat frame = sag_test::backgroundFrame(3);
  // Two isolated bright specks (single cells) and one 3x3-cell blob of skin colour.
  frame(cv::Rect(200, 60, 4, 4)).setTo(cv::Scalar(255, 255, 255));
  frame(cv::Rect(40, 120, 3, 3)).setTo(cv::Scalar(250, 180, 150));
  frame(cv::Rect(100, 140, 12, 12)).setTo(cv::Scalar(210, 150, 120));
  ImageSegmenter segmenter = learnedSegmenter(SegmentationMode::kPlate);
  std::vector<QuadtreeLeaf> leaves;
  const std::size_t with_removal = segmenter.segment(frame, &leaves).gaussians.size();
  cv::Mat blob = cv::Mat::zeros(frame.size(), CV_8UC1);
  blob(cv::Rect(100, 140, 12, 12)).setTo(255);
  EXPECT_DOUBLE_EQ(overlapWith(blob, leaves).precision, 1.0);
  EXPECT_DOUBLE_EQ(overlapWith(blob, leaves).recall, 1.0);
  SegmentationParams keep = segmenter.params();
  keep.remove_isolated_cells = false;
  segmenter.setParams(keep);
  // Each speck is one cell, hence one more leaf.
  EXPECT_EQ(segmenter.segment(frame, &leaves).gaussians.size(), with_removal + 2);
}

TEST(Background, WorksOnOddImageSizes) {
  // 321 x 243: the last cell column/row and the last leaves are clipped by the border.
  sag_test::SceneOptions o;
  o.width = 321;
  o.height = 243;
  SegmentationParams p;
  p.mode = SegmentationMode::kPlate;
  ImageSegmenter segmenter(p);
  for (unsigned seed = 0; seed < 10; ++seed) {
    o.seed = seed;
    segmenter.addBackgroundFrame(sag_test::scene(o));
  }
  EXPECT_EQ(segmenter.backgroundPlate().cellsX(), 81);
  EXPECT_EQ(segmenter.backgroundPlate().cellsY(), 61);
  o.seed = 77;
  EXPECT_EQ(segmenter.segment(sag_test::scene(o)).gaussians.size(), 0u);
  o.hand = o.sleeve = o.shadow = true;
  std::vector<QuadtreeLeaf> leaves;
  segmenter.segment(sag_test::scene(o), &leaves);
  const cv::Mat hand = sag_test::handMask(o);
  EXPECT_GT(overlapWith(hand, leaves).recall, 0.9);
  EXPECT_GT(overlapWith(dilate(hand, 4), leaves).precision, 0.999);
  // A blob in the clipped bottom-right corner is found and its leaves stay inside the image.
  cv::Mat frame = sag_test::scene(o);
  frame(cv::Rect(312, 236, 9, 7)).setTo(cv::Scalar(214, 158, 128));
  segmenter.segment(frame, &leaves);
  int corner = 0;
  for (const QuadtreeLeaf& l : leaves) {
    EXPECT_LE(l.x + l.width, 321);
    EXPECT_LE(l.y + l.height, 243);
    if (l.x >= 312 && l.y >= 236) ++corner;
  }
  EXPECT_GT(corner, 0);
  const cv::Mat mask = segmenter.foregroundMask(frame);
  EXPECT_EQ(mask.size(), frame.size());
  EXPECT_EQ(mask.at<unsigned char>(242, 320), 255);
}

TEST(Background, RejectsImagesOfAnotherSize) {
  const ImageSegmenter segmenter = learnedSegmenter(SegmentationMode::kPlate);
  const std::string message =
      inputErrorMessage([&] { segmenter.segment(sag_test::backgroundFrame(0, 640, 480)); });
  EXPECT_NE(message.find("640x480"), std::string::npos) << message;
  EXPECT_NE(message.find("320x240"), std::string::npos) << message;
  EXPECT_THROW(segmenter.foregroundMask(sag_test::backgroundFrame(0, 320, 200)), InputError);
  ImageSegmenter learning = learnedSegmenter(SegmentationMode::kPlate);
  EXPECT_THROW(learning.addBackgroundFrame(sag_test::backgroundFrame(0, 321, 240)), InputError);
  EXPECT_EQ(learning.backgroundFrameCount(), 10);
  // Mode none and skin do not use the plate: any size is fine.
  SegmentationParams skin = learning.params();
  skin.mode = SegmentationMode::kSkin;
  learning.setParams(skin);
  EXPECT_NO_THROW(learning.segment(sag_test::backgroundFrame(0, 640, 480)));
}

TEST(Background, SaveAndLoadRoundTrip) {
  const ImageSegmenter learned = learnedSegmenter(SegmentationMode::kPlate);
  const std::string path = testing::TempDir() + "sag_background_plate_test.yml.gz";
  learned.saveBackground(path);
  ImageSegmenter loaded;
  loaded.loadBackground(path);
  EXPECT_TRUE(loaded.backgroundReady());
  EXPECT_EQ(loaded.backgroundFrameCount(), 10);
  EXPECT_LT(
      cv::norm(loaded.backgroundPlate().mean(), learned.backgroundPlate().mean(), cv::NORM_INF),
      1e-3);
  EXPECT_LT(
      cv::norm(loaded.backgroundPlate().spread(), learned.backgroundPlate().spread(), cv::NORM_INF),
      1e-3);
  sag_test::SceneOptions o;
  o.hand = o.sleeve = o.shadow = true;
  const cv::Mat frame = sag_test::scene(o);
  const ImageSoG a = learned.segment(frame), b = loaded.segment(frame);
  ASSERT_EQ(a.gaussians.size(), b.gaussians.size());
  for (std::size_t i = 0; i < a.gaussians.size(); ++i) {
    EXPECT_EQ(a.gaussians[i].mean, b.gaussians[i].mean);
  }
  // More frames can be added to a loaded plate.
  loaded.addBackgroundFrame(sag_test::backgroundFrame(20));
  EXPECT_EQ(loaded.backgroundFrameCount(), 11);
  // Errors: missing file, another cell size, not a plate file, empty plate.
  EXPECT_NE(
      inputErrorMessage([&] { loaded.loadBackground(path + ".missing"); }).find("cannot open"),
      std::string::npos);
  SegmentationParams coarse;
  coarse.cell_size = 8;
  ImageSegmenter other(coarse);
  EXPECT_NE(inputErrorMessage([&] { other.loadBackground(path); }).find("cell size"),
            std::string::npos);
  EXPECT_EQ(other.backgroundFrameCount(), 0);
  const std::string not_plate = testing::TempDir() + "sag_not_a_plate.yml";
  {
    cv::FileStorage fs(not_plate, cv::FileStorage::WRITE);
    fs << "something" << 3;
  }
  EXPECT_NE(inputErrorMessage([&] { other.loadBackground(not_plate); }).find("not a background"),
            std::string::npos);
  EXPECT_THROW(ImageSegmenter().saveBackground(path), InputError);
  std::remove(path.c_str());
  std::remove(not_plate.c_str());
}

// ---- skin gate
// -----------------------------------------------------------------------------------

TEST(Skin, GateKeepsSkinTones) {
  const SkinParams params;
  const double tones[][3] = {
      {255, 224, 196},  // very fair
      {234, 192, 134},  // light, warm
      {214, 158, 128},  // the synthetic hand
      {198, 134, 66},   // tan
      {141, 85, 36},    // brown
      {92, 51, 23},     // dark brown
      {128, 95, 77},    // light skin in shadow
      {230, 170, 175},  // pinkish under cool light (hue ~355)
  };
  for (const auto& t : tones) {
    EXPECT_TRUE(isSkinColour(Eigen::Vector3d(t[0], t[1], t[2]), params))
        << t[0] << "," << t[1] << "," << t[2];
  }
}

TEST(Skin, GateRejectsNonSkinColours) {
  const SkinParams params;
  const double colours[][3] = {
      {40, 60, 200},    // blue
      {50, 160, 60},    // green
      {128, 128, 128},  // grey
      {130, 125, 120},  // warm grey
      {250, 250, 250},  // white
      {20, 20, 24},     // black
      {128, 40, 160},   // purple
      {40, 200, 210},   // cyan
      {220, 20, 20},    // vivid red
      {230, 220, 40},   // yellow
  };
  for (const auto& c : colours) {
    EXPECT_FALSE(isSkinColour(Eigen::Vector3d(c[0], c[1], c[2]), params))
        << c[0] << "," << c[1] << "," << c[2];
  }
}

TEST(Skin, HueRangeIsCircularAndConfigurable) {
  SkinParams params;
  const Eigen::Vector3d pink(230, 170, 175);  // hue ~355
  EXPECT_TRUE(isSkinColour(pink, params));
  params.hue_min_deg = 0.0;
  EXPECT_FALSE(isSkinColour(pink, params));
  EXPECT_TRUE(isSkinColour(Eigen::Vector3d(214, 158, 128), params));
  params.hue_min_deg = 200.0;  // a blue glove
  params.hue_max_deg = 260.0;
  EXPECT_TRUE(isSkinColour(Eigen::Vector3d(40, 60, 200), params));
  EXPECT_FALSE(isSkinColour(Eigen::Vector3d(214, 158, 128), params));
}

TEST(Skin, ModeKeepsOnlySkinRegions) {
  // Quadrants: skin, blue, green, grey.
  cv::Mat img(128, 128, CV_8UC3);
  img(cv::Rect(0, 0, 64, 64)).setTo(cv::Scalar(214, 158, 128));
  img(cv::Rect(64, 0, 64, 64)).setTo(cv::Scalar(40, 60, 200));
  img(cv::Rect(0, 64, 64, 64)).setTo(cv::Scalar(50, 160, 60));
  img(cv::Rect(64, 64, 64, 64)).setTo(cv::Scalar(128, 128, 128));
  SegmentationParams p;
  p.mode = SegmentationMode::kSkin;
  const ImageSegmenter segmenter(p);
  EXPECT_EQ(segmenter.effectiveMode(), SegmentationMode::kSkin);
  std::vector<QuadtreeLeaf> leaves;
  const ImageSoG sog = segmenter.segment(img, &leaves);
  ASSERT_EQ(sog.gaussians.size(), 4u);  // the skin quadrant: four 32x32 leaves
  cv::Mat skin = cv::Mat::zeros(128, 128, CV_8UC1);
  skin(cv::Rect(0, 0, 64, 64)).setTo(255);
  EXPECT_DOUBLE_EQ(overlapWith(skin, leaves).precision, 1.0);
  EXPECT_DOUBLE_EQ(overlapWith(skin, leaves).recall, 1.0);
  EXPECT_EQ(cv::countNonZero(segmenter.foregroundMask(img) != skin), 0);
}

// refine_border_pixels: with the skin gate the cells on the silhouette's border are decided
// pixel by pixel, so the foreground and the SoG hold the disc's pixels, not whole cells of it.
TEST(Skin, BorderCellsAreDecidedPixelByPixel) {
  const cv::Scalar skin(214, 158, 128), grey(128, 128, 128);
  cv::Mat img(120, 160, CV_8UC3, grey);
  const cv::Point centre(77, 61);  // the edge crosses the 4-pixel cells at every angle
  cv::circle(img, centre, 29, skin, cv::FILLED);
  cv::Mat truth;
  cv::inRange(img, skin, skin, truth);
  struct Run {
    cv::Mat mask;
    ImageSoG sog;
  };
  auto run = [&](SegmentationMode mode, bool refine) {
    SegmentationParams p;
    p.mode = mode;
    p.refine_border_pixels = refine;
    ImageSegmenter segmenter(p);
    for (int i = 0; i < p.background.frames; ++i)
      segmenter.addBackgroundFrame(cv::Mat(img.size(), CV_8UC3, grey));
    Run r;
    r.sog = segmenter.segmentFrame(img);
    r.mask = segmenter.lastForegroundMask();
    return r;
  };
  auto precision = [&](const cv::Mat& m) {
    return static_cast<double>(cv::countNonZero(m & truth)) / cv::countNonZero(m);
  };
  auto recall = [&](const cv::Mat& m) {
    return static_cast<double>(cv::countNonZero(m & truth)) / cv::countNonZero(truth);
  };
  const Run cells = run(SegmentationMode::kSkin, false);
  const Run pixels = run(SegmentationMode::kSkin, true);
  EXPECT_LT(precision(cells.mask), 0.97);  // whole border cells bring grey pixels
  EXPECT_GT(precision(pixels.mask), 0.995);
  EXPECT_GE(recall(pixels.mask), recall(cells.mask) - 1e-9);  // only grey pixels are dropped
  EXPECT_GT(recall(pixels.mask), 0.95);
  // The SoG stands for exactly the kept pixels: each leaf's mass 2 pi sigma^2 is its pixel count
  // (sigma_per_leaf_size = 1 / sqrt(2 pi)), and their centroid is the disc's centre.
  double area = 0.0;
  Eigen::Vector2d moment = Eigen::Vector2d::Zero();
  for (const ImageGaussian& g : pixels.sog.gaussians) {
    const double mass = 2.0 * M_PI * g.sigma * g.sigma;
    area += mass;
    moment += mass * g.mean;
  }
  EXPECT_NEAR(area, cv::countNonZero(pixels.mask), 1e-6 * area);
  EXPECT_LT((moment / area - Eigen::Vector2d(centre.x, centre.y)).norm(), 0.25);
  EXPECT_GT(pixels.sog.gaussians.size(), cells.sog.gaussians.size());  // border leaves are cells

  // With the plate the cells stay as they are.
  const Run plate_cells = run(SegmentationMode::kPlate, false);
  const Run plate_pixels = run(SegmentationMode::kPlate, true);
  ASSERT_EQ(plate_pixels.sog.gaussians.size(), plate_cells.sog.gaussians.size());
  for (size_t i = 0; i < plate_cells.sog.gaussians.size(); ++i) {
    EXPECT_EQ(plate_pixels.sog.gaussians[i].mean, plate_cells.sog.gaussians[i].mean);
    EXPECT_EQ(plate_pixels.sog.gaussians[i].sigma, plate_cells.sog.gaussians[i].sigma);
  }
  EXPECT_EQ(cv::countNonZero(plate_pixels.mask != plate_cells.mask), 0);
}

TEST(Skin, DarkUnsaturatedRuleSeparatesSleeveFromSkin) {
  const BackgroundParams params;
  EXPECT_TRUE(isDarkNonSkin(Eigen::Vector3d(22, 22, 26), params));   // black sleeve
  EXPECT_TRUE(isDarkNonSkin(Eigen::Vector3d(60, 58, 55), params));   // dark grey fabric
  EXPECT_TRUE(isDarkNonSkin(Eigen::Vector3d(25, 12, 10), params));   // too dark, even if tinted
  EXPECT_FALSE(isDarkNonSkin(Eigen::Vector3d(92, 51, 23), params));  // dark brown skin
  EXPECT_FALSE(isDarkNonSkin(Eigen::Vector3d(128, 95, 77), params));
  EXPECT_FALSE(isDarkNonSkin(Eigen::Vector3d(40, 60, 200), params));  // saturated blue
}

// The subsampled integral image (segmentation_internal.h) gives the exact sums of R, G, B and of
// their squares over rectangles on its grid (every third left and top line from the image's
// corner, every other right and bottom line after them), for several image sizes and grid steps;
// and on white images, whose 16 x 16 blocks fill the 16-bit block sums of the horizontal pass to
// 65280 and whose bands of 256 rows fill its column sums.
TEST(ColourIntegral, GivesTheExactSumsOverGridRectangles) {
  std::mt19937 random(7);
  std::uniform_int_distribution<int> byte(0, 255);
  struct Size {
    int width, height, step;
    bool white;
  };
  for (const Size& size :
       {Size{96, 64, 4, false}, Size{37, 23, 4, false}, Size{50, 29, 8, false},
        Size{19, 17, 2, false}, Size{13, 11, 1, false}, Size{70, 40, 16, false},
        Size{3, 5, 4, false}, Size{70, 40, 16, true}, Size{33, 300, 256, true}}) {
    cv::Mat rgb(size.height, size.width, CV_8UC3);
    for (auto it = rgb.begin<cv::Vec3b>(); it != rgb.end<cv::Vec3b>(); ++it) {
      *it = size.white ? cv::Vec3b(255, 255, 255)
                       : cv::Vec3b(byte(random), byte(random), byte(random));
    }
    detail::ColourIntegral integral;
    integral.compute(rgb, size.step);
    // Every grid line: multiples of the step, and the border.
    auto lines = [&](int extent) {
      std::vector<int> at;
      for (int v = 0; v < extent; v += size.step) at.push_back(v);
      at.push_back(extent);
      return at;
    };
    const std::vector<int> xs = lines(size.width), ys = lines(size.height);
    int checked = 0;
    for (size_t a = 0; a < xs.size(); a += 3) {
      for (size_t b = a + 1; b < xs.size(); b += 2) {
        for (size_t c = 0; c < ys.size(); c += 3) {
          for (size_t d = c + 1; d < ys.size(); d += 2) {
            std::uint64_t expected[6] = {0, 0, 0, 0, 0, 0};
            for (int y = ys[c]; y < ys[d]; ++y) {
              for (int x = xs[a]; x < xs[b]; ++x) {
                const cv::Vec3b& p = rgb.at<cv::Vec3b>(y, x);
                for (int k = 0; k < 3; ++k) {
                  expected[k] += p[k];
                  expected[3 + k] += p[k] * p[k];
                }
              }
            }
            std::uint32_t sums[6];
            integral.region(xs[a], ys[c], xs[b], ys[d], sums);
            for (int k = 0; k < 6; ++k) {
              ASSERT_EQ(sums[k], expected[k])
                  << "lane " << k << " of [" << xs[a] << ", " << xs[b] << ") x [" << ys[c] << ", "
                  << ys[d] << ") in a " << size.width << "x" << size.height << " image, step "
                  << size.step;
            }
            ++checked;
          }
        }
      }
    }
    EXPECT_GT(checked, 0);
  }
}

TEST(ColourIntegral, CellMeansAreTheMeansOfTheirPixels) {
  std::mt19937 random(11);
  std::uniform_int_distribution<int> byte(0, 255);
  struct Size {
    int width, height, step, cell_size;
  };
  // Whole cells only, cells cut by the right and bottom borders, cells of several grid steps.
  for (const Size& size :
       {Size{64, 32, 4, 4}, Size{37, 23, 4, 4}, Size{50, 29, 4, 8}, Size{19, 17, 2, 8},
        Size{13, 11, 1, 2}, Size{70, 41, 16, 16}, Size{3, 5, 4, 4}}) {
    cv::Mat rgb(size.height, size.width, CV_8UC3);
    for (auto it = rgb.begin<cv::Vec3b>(); it != rgb.end<cv::Vec3b>(); ++it) {
      *it = cv::Vec3b(byte(random), byte(random), byte(random));
    }
    detail::ColourIntegral integral;
    integral.compute(rgb, size.step);
    std::vector<float> means;
    detail::cellMeans(integral, size.cell_size, means);
    const int cells_x = detail::cellCount(size.width, size.cell_size);
    const int cells_y = detail::cellCount(size.height, size.cell_size);
    ASSERT_EQ(means.size(), static_cast<size_t>(3 * cells_x * cells_y));
    for (int cy = 0; cy < cells_y; ++cy) {
      for (int cx = 0; cx < cells_x; ++cx) {
        double sum[3] = {0, 0, 0};
        int pixels = 0;
        for (int y = cy * size.cell_size; y < std::min((cy + 1) * size.cell_size, size.height);
             ++y) {
          for (int x = cx * size.cell_size; x < std::min((cx + 1) * size.cell_size, size.width);
               ++x) {
            for (int k = 0; k < 3; ++k) sum[k] += rgb.at<cv::Vec3b>(y, x)[k];
            ++pixels;
          }
        }
        for (int k = 0; k < 3; ++k) {
          ASSERT_NEAR(means[3 * (cy * cells_x + cx) + k], sum[k] / pixels, 1e-4)
              << "channel " << k << " of cell (" << cx << ", " << cy << ") in a " << size.width
              << "x" << size.height << " image, cells of " << size.cell_size << ", step "
              << size.step;
        }
      }
    }
  }
}

TEST(Background, DifferingCellsIsTheCellTestOverAWholeFrame) {
  // A plate of noisy, coloured cells; frames with the plate itself, its shadows, other colours
  // and colours at the tolerance's edge: the whole-frame test must agree with the per-cell one.
  std::mt19937 random(5);
  std::uniform_real_distribution<float> colour(0.0f, 255.0f), noise(-6.0f, 6.0f), unit(0.0f, 1.0f);
  const int width = 52, height = 36, cell_size = 4;
  const int cells = detail::cellCount(width, cell_size) * detail::cellCount(height, cell_size);
  std::vector<float> base(3 * cells);
  for (float& v : base) v = colour(random);
  BackgroundPlate plate(cell_size);
  for (int frame = 0; frame < 8; ++frame) {
    std::vector<float> means = base;
    for (float& v : means) v = std::clamp(v + noise(random), 0.0f, 255.0f);
    plate.addFrame(width, height, means);
  }
  const cv::Mat mean = plate.mean(), spread = plate.spread();
  const BackgroundParams params;
  int differing = 0, shadows = 0;
  for (int frame = 0; frame < 6; ++frame) {
    std::vector<float> means(3 * cells);
    for (int i = 0; i < cells; ++i) {
      const cv::Vec3f m = mean.at<cv::Vec3f>(i / mean.cols, i % mean.cols);
      const cv::Vec3f s = spread.at<cv::Vec3f>(i / mean.cols, i % mean.cols);
      const float kind = unit(random);
      // At the edge: a colour distance of 0.8-1.2 tolerances, shared by the channels.
      const float edge = std::sqrt((0.8f + 0.4f * unit(random)) / 3.0f);
      for (int k = 0; k < 3; ++k) {
        float v = m[k];
        if (kind < 0.25f) {
          v = m[k] + noise(random);  // the plate
        } else if (kind < 0.5f) {
          v = m[k] * (0.3f + 0.6f * unit(random));  // a shadow or something darker
        } else if (kind < 0.75f) {
          v = colour(random);  // something else
        } else {
          const float tolerance = std::max(static_cast<float>(params.k_sigma) * s[k],
                                           static_cast<float>(params.min_tolerance));
          v = m[k] + (unit(random) < 0.5f ? -1.0f : 1.0f) * tolerance * edge;
        }
        means[3 * i + k] = v;
      }
    }
    std::vector<unsigned char> differs;
    plate.differingCells(means, params, &differs);
    ASSERT_EQ(differs.size(), static_cast<size_t>(cells));
    for (int i = 0; i < cells; ++i) {
      const bool background = plate.isBackground(i, &means[3 * i], params);
      ASSERT_EQ(differs[i] != 0, !background) << "cell " << i << " of frame " << frame;
      differing += differs[i];
      if (background) {
        const cv::Vec3f m = mean.at<cv::Vec3f>(i / mean.cols, i % mean.cols);
        const double darker =
            (means[3 * i] + means[3 * i + 1] + means[3 * i + 2]) / (m[0] + m[1] + m[2]);
        shadows += darker < 0.8 ? 1 : 0;
      }
    }
  }
  // Every kind of cell was met: both answers, and shadows kept as background.
  EXPECT_GT(differing, cells);
  EXPECT_LT(differing, 5 * cells);
  EXPECT_GT(shadows, 0);
  // A frame of another size is named.
  std::vector<unsigned char> differs;
  try {
    plate.differingCells(std::vector<float>(3 * cells - 3), params, &differs);
    FAIL() << "a frame of the wrong size was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(std::to_string(3 * cells)), std::string::npos) << e.what();
  }
}
