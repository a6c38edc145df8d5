#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "sag_hand_tracker/apps/metrics.h"
#include "sag_hand_tracker/apps/plot.h"

using namespace sag_hand_tracker;

TEST(Metrics, MeanFingertipErrorAveragesTheFiveTips) {
  Fingertips a, b;
  for (int f = 0; f < kNumFingers; ++f) {
    a[f] = Eigen::Vector3d(f, 0, 0);
    b[f] = a[f] + Eigen::Vector3d(0, 0.001 * (f + 1), 0);
  }
  EXPECT_NEAR(meanFingertipError(a, b), 0.003, 1e-12);
}

TEST(Metrics, SummaryGivesMeanSdAndTable1Percentages) {
  const ErrorSummary s = summariseErrors({10.0, 18.0, 22.0, 40.0});
  EXPECT_EQ(s.frames, 4);
  EXPECT_NEAR(s.mean_mm, 22.5, 1e-12);
  EXPECT_NEAR(s.sd_mm, std::sqrt((12.5 * 12.5 + 4.5 * 4.5 + 0.5 * 0.5 + 17.5 * 17.5) / 4), 1e-12);
  EXPECT_NEAR(s.percent_below[0], 25.0, 1e-12);   // < 15
  EXPECT_NEAR(s.percent_below[1], 50.0, 1e-12);   // < 20
  EXPECT_NEAR(s.percent_below[2], 75.0, 1e-12);   // < 25
  EXPECT_NEAR(s.percent_below[3], 75.0, 1e-12);   // < 30
  EXPECT_NEAR(s.percent_below[4], 100.0, 1e-12);  // < 45
  EXPECT_EQ(summariseErrors({}).frames, 0);
}

TEST(Plot, WritesAPngWithTheSeriesDrawn) {
  PlotSeries series{"sag", {0, 1, 2, 3}, {5, 10, 7, 12}, {}, cv::Scalar(255, 0, 0)};
  const cv::Mat plot = linePlot({series}, "error", "frame", "mm", 400, 300);
  ASSERT_EQ(plot.rows, 300);
  // Some pixels carry the series colour.
  int blue = 0;
  for (int y = 0; y < plot.rows; ++y) {
    for (int x = 0; x < plot.cols; ++x) {
      const cv::Vec3b p = plot.at<cv::Vec3b>(y, x);
      blue += (p[0] > 200 && p[1] < 80 && p[2] < 80) ? 1 : 0;
    }
  }
  EXPECT_GT(blue, 100);
  const std::string path = testing::TempDir() + "/plot.png";
  writePng(path, plot);
  EXPECT_EQ(cv::imread(path).rows, 300);
  EXPECT_THROW(writePng("/nonexistent/dir/plot.png", plot), InputError);
}
