#include <gtest/gtest.h>

#include <cmath>
#include <limits>
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

namespace {

Eigen::Matrix3d rotationAbout(const Eigen::Vector3d& axis, double degrees) {
  return Eigen::AngleAxisd(degrees * M_PI / 180.0, axis.normalized()).toRotationMatrix();
}

}  // namespace

TEST(Metrics, OrientationErrorOfTheTruthItselfIsZero) {
  const Eigen::Matrix3d truth =
      rotationAbout(Eigen::Vector3d(0.3, -1.0, 0.4), 123.0);  // any orientation
  const Eigen::Vector3d wrist(0.01, -0.05, 0.15);
  const OrientationError e = orientationError(truth, wrist, truth, wrist);
  EXPECT_NEAR(e.forward_deg, 0.0, 1e-6);
  EXPECT_NEAR(e.back_normal_deg, 0.0, 1e-6);
  EXPECT_EQ(e.wrist_m, 0.0);
  EXPECT_FALSE(e.reversed());
  EXPECT_FALSE(e.rolledOver());
}

TEST(Metrics, OrientationErrorFlagsRolledOverAndReversedHands) {
  const Eigen::Matrix3d truth = rotationAbout(Eigen::Vector3d(1.0, 2.0, -0.5), 70.0);
  const Eigen::Vector3d wrist(0.0, -0.06, 0.15);
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                        z = Eigen::Vector3d::UnitZ();
  // Rotations in the palm frame (applied on the right): about the hand's long axis (roll), about
  // the back-of-hand normal (a turn in the palm's plane), about the axis across the palm.
  auto tracked = [&](const Eigen::Vector3d& palm_axis, double deg) {
    return orientationError(truth * rotationAbout(palm_axis, deg), wrist, truth, wrist);
  };
  // Palm up where the palm is down: rolled over, not reversed.
  const OrientationError roll = tracked(x, 180.0);
  EXPECT_TRUE(roll.rolledOver());
  EXPECT_FALSE(roll.reversed());
  EXPECT_NEAR(roll.forward_deg, 0.0, 1e-6);
  EXPECT_NEAR(roll.back_normal_deg, 180.0, 1e-6);
  // Fingers where the wrist is, in the palm's plane: reversed, not rolled over.
  const OrientationError turn = tracked(z, 180.0);
  EXPECT_TRUE(turn.reversed());
  EXPECT_FALSE(turn.rolledOver());
  // Flipped about the axis across the palm: both.
  const OrientationError flip = tracked(y, 150.0);
  EXPECT_TRUE(flip.reversed());
  EXPECT_TRUE(flip.rolledOver());
  EXPECT_NEAR(flip.forward_deg, 150.0, 1e-6);
  EXPECT_NEAR(flip.back_normal_deg, 150.0, 1e-6);
  // Small and large errors that stay on the right side are not flagged.
  for (const double deg : {5.0, 45.0, 89.0}) {
    SCOPED_TRACE(deg);
    EXPECT_FALSE(tracked(x, deg).rolledOver());
    EXPECT_FALSE(tracked(z, deg).reversed());
    EXPECT_FALSE(tracked(y, deg).reversed());
    EXPECT_FALSE(tracked(y, deg).rolledOver());
    EXPECT_NEAR(tracked(y, deg).forward_deg, deg, 1e-6);
  }
  // Either side of the threshold (more than 90 degrees is the rule).
  EXPECT_TRUE(tracked(x, 90.5).rolledOver());
  EXPECT_TRUE(tracked(z, -90.5).reversed());
  EXPECT_FALSE(tracked(z, 89.5).reversed());
  EXPECT_FALSE(tracked(x, -89.5).rolledOver());
  // A roll about the hand's axis of any size never reverses the hand.
  EXPECT_FALSE(tracked(x, 179.0).reversed());
}

TEST(Metrics, OrientationErrorUsesTheGivenForwardDirectionAndWrist) {
  const Eigen::Matrix3d truth = Eigen::Matrix3d::Identity();
  // A turn of 100 degrees in the palm's plane about z: the x axis is reversed, but a forward
  // direction at 60 degrees from x (towards y) turns by the same 100 degrees, while the wrist
  // error is the distance of the roots.
  const Eigen::Matrix3d turned = rotationAbout(Eigen::Vector3d::UnitZ(), 100.0);
  const Eigen::Vector3d forward(std::cos(M_PI / 3), std::sin(M_PI / 3), 0.0);
  const OrientationError e = orientationError(turned, Eigen::Vector3d(0.03, 0.04, 0.0), truth,
                                              Eigen::Vector3d::Zero(), 2.0 * forward);
  EXPECT_NEAR(e.forward_deg, 100.0, 1e-6);
  EXPECT_TRUE(e.reversed());
  EXPECT_FALSE(e.rolledOver());
  EXPECT_NEAR(e.wrist_m, 0.05, 1e-12);
}

TEST(Metrics, OrientationErrorOfANonFinitePoseIsAFailureNotANumber) {
  Eigen::Matrix3d bad = Eigen::Matrix3d::Identity();
  bad(0, 0) = std::numeric_limits<double>::quiet_NaN();  // in the forward and the normal axes
  bad(2, 2) = std::numeric_limits<double>::quiet_NaN();
  const OrientationError e = orientationError(bad, Eigen::Vector3d::Zero(),
                                              Eigen::Matrix3d::Identity(), Eigen::Vector3d::Zero());
  EXPECT_TRUE(std::isnan(e.forward_deg));
  EXPECT_TRUE(e.reversed());
  EXPECT_TRUE(e.rolledOver());
  EXPECT_TRUE(std::isnan(angleBetweenDeg(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX())));
  EXPECT_NEAR(angleBetweenDeg(Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitX()), 180.0, 1e-9);
  // Near-parallel directions keep their small angle (no acos rounding to 0).
  EXPECT_NEAR(angleBetweenDeg(Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(1, 1e-7, 0)),
              1e-7 * 180.0 / M_PI, 1e-12);
}
