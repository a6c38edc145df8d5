#include <gtest/gtest.h>

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
