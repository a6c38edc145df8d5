#include <gtest/gtest.h>

#include <cmath>

#include "sag_hand_tracker/energy/colour.h"

using namespace sag_hand_tracker;

TEST(Colour, RgbToHsvPrimaries) {
  EXPECT_NEAR(rgbToHsv(255, 0, 0)[0], 0.0, 1e-9);
  EXPECT_NEAR(rgbToHsv(0, 255, 0)[0], 120.0, 1e-9);
  EXPECT_NEAR(rgbToHsv(0, 0, 255)[0], 240.0, 1e-9);
  EXPECT_NEAR(rgbToHsv(255, 0, 255)[0], 300.0, 1e-9);
  const Hsv grey = rgbToHsv(128, 128, 128);
  EXPECT_NEAR(grey[1], 0.0, 1e-12);
  EXPECT_NEAR(grey[2], 128.0 / 255.0, 1e-12);
}

TEST(Colour, WendlandShape) {
  EXPECT_DOUBLE_EQ(wendland(0.0), 1.0);
  EXPECT_DOUBLE_EQ(wendland(1.0), 0.0);
  EXPECT_DOUBLE_EQ(wendland(2.0), 0.0);
  EXPECT_GT(wendland(0.3), wendland(0.6));
  EXPECT_NEAR(wendland(0.5), 0.0625 * 3.0, 1e-12);
}

TEST(Colour, HueIsCircular) {
  ColourSimilarityParams params;
  const Hsv a(355.0, 0.6, 0.7), b(5.0, 0.6, 0.7), c(45.0, 0.6, 0.7);
  EXPECT_GT(colourSimilarity(a, b, params), colourSimilarity(b, c, params));
  EXPECT_NEAR(colourSimilarity(a, b, params),
              colourSimilarity(Hsv(10, 0.6, 0.7), Hsv(20, 0.6, 0.7), params), 1e-12);
  EXPECT_DOUBLE_EQ(colourSimilarity(a, a, params), 1.0);
  EXPECT_DOUBLE_EQ(colourSimilarity(Hsv(20, 0.6, 0.7), Hsv(200, 0.6, 0.7), params), 0.0);
}

TEST(Colour, HsvToRgbInvertsRgbToHsv) {
  for (const Eigen::Vector3d& rgb :
       {Eigen::Vector3d(200, 150, 120), Eigen::Vector3d(10, 240, 30), Eigen::Vector3d(90, 20, 250),
        Eigen::Vector3d(128, 128, 128)}) {
    const Eigen::Vector3d back = hsvToRgb(rgbToHsv(rgb[0], rgb[1], rgb[2])) * 255.0;
    EXPECT_LT((back - rgb).norm(), 1e-9) << rgb.transpose();
  }
}

TEST(Colour, MeanColourTakesTheShorterWayRoundTheHueCircle) {
  const Hsv mean = meanColour({Hsv(350, 0.5, 0.4), Hsv(10, 0.5, 0.8)}, {1.0, 1.0});
  EXPECT_NEAR(std::remainder(mean[0], 360.0), 0.0, 1e-9);
  EXPECT_NEAR(mean[1], 0.5, 1e-12);
  EXPECT_NEAR(mean[2], 0.6, 1e-12);
  // Weights count, and a grey colour has no say in the hue.
  const Hsv weighted = meanColour({Hsv(20, 0.5, 0.5), Hsv(200, 0.0, 0.5)}, {1.0, 3.0});
  EXPECT_NEAR(weighted[0], 20.0, 1e-9);
  EXPECT_NEAR(weighted[1], 0.125, 1e-12);
  EXPECT_EQ(meanColour({}, {}), Hsv::Zero());
}

TEST(Colour, CastMapsTheImageMeanOntoTheModelMean) {
  const Hsv model(20.0, 0.45, 0.80), pale(12.0, 0.24, 0.70), dark(30.0, 0.50, 0.30);
  for (const Hsv& image : {pale, dark}) {
    const ColourCast cast = colourCast(model, image, 3.0);
    EXPECT_LT((cast.apply(image) - model).norm(), 1e-9) << image.transpose();
  }
  // Hue shifts wrap; gains are limited; a grey foreground leaves the hue alone.
  EXPECT_NEAR(colourCast(Hsv(5, 0.5, 0.5), Hsv(355, 0.5, 0.5), 3.0).hue_shift_deg, 10.0, 1e-9);
  EXPECT_DOUBLE_EQ(colourCast(model, Hsv(20, 0.45, 0.05), 3.0).value_gain, 3.0);
  EXPECT_DOUBLE_EQ(colourCast(model, Hsv(200, 0.0, 0.8), 3.0).hue_shift_deg, 0.0);
  const Hsv clamped = ColourCast{350.0, 4.0, 4.0}.apply(Hsv(20, 0.5, 0.5));
  EXPECT_NEAR(clamped[0], 10.0, 1e-9);
  EXPECT_DOUBLE_EQ(clamped[1], 1.0);
  EXPECT_DOUBLE_EQ(clamped[2], 1.0);
}
