#include <gtest/gtest.h>

#include "sag_hand_tracker/apps/metrics.h"

#include "sag_hand_tracker/tracking/tracker.h"
#include "test_support/synthetic_scene.h"

using namespace sag_hand_tracker;
using namespace sag_test;

namespace {}  // namespace

TEST(Tracker, WaitsWhileNoCameraSeesTheHand) {
  const HandModel model = loadHandModel(modelPath("sag"));
  HandTracker tracker(model, TrackerParams());
  std::vector<CameraObservation> empty;
  for (const Camera& camera : fiveCameraRig()) empty.push_back({camera, ImageSoG()});
  const FrameResult result = tracker.update(empty, 0.0);
  EXPECT_EQ(result.status, TrackStatus::kWaiting);
  EXPECT_FALSE(result.has_pose);
}

// Hypothesis start: no initial pose is given; the hand is found from the foreground alone.
TEST(Tracker, StartsAutomaticallyFromHypotheses) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  // An unusual orientation: fingers pointing along -y, palm tilted.
  Pose truth = typicalPose(model);
  truth.rotation = rotationFromVector(Eigen::Vector3d(0.3, 0.0, -M_PI / 2));
  truth.translation = Eigen::Vector3d(0.02, 0.05, 0.17);
  HandTracker tracker(model, TrackerParams());
  const FrameResult result = tracker.update(modelObservations(model, truth, cameras, 3.0), 1.0);
  ASSERT_TRUE(result.has_pose);
  EXPECT_EQ(result.status, TrackStatus::kStarted);
  EXPECT_FALSE(result.restarted);
  const double error = meanFingertipError(result.fingertips, fingertips(model, truth));
  EXPECT_LT(error, 0.02) << "fingertip error after start " << error * 1000 << " mm";
}

// Warm-started tracking of a moving hand, then a jump that loses the track and restarts it.
TEST(Tracker, TracksMotionAndRestartsWhenLost) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  HandTracker tracker(model, TrackerParams());
  Pose truth = typicalPose(model);
  double worst = 0.0;
  for (int frame = 0; frame < 20; ++frame) {
    truth.translation.x() += 0.003;  // 7.5 cm/s at 25 fps
    truth.joints[4] = 0.2 + 0.4 * std::sin(frame * 0.2);
    const FrameResult result =
        tracker.update(modelObservations(model, truth, cameras, 3.0), frame * 0.04);
    ASSERT_TRUE(result.has_pose);
    if (frame > 0) {
      EXPECT_EQ(result.status, TrackStatus::kTracking) << "frame " << frame;
    }
    if (frame > 2)
      worst = std::max(worst, meanFingertipError(result.fingertips, fingertips(model, truth)));
  }
  EXPECT_LT(worst, 0.015) << "worst fingertip error " << worst * 1000 << " mm";

  // The hand jumps 25 cm away: warm start cannot follow; the tracker restarts by itself.
  truth.translation += Eigen::Vector3d(-0.1, 0.2, 0.05);
  const FrameResult jumped = tracker.update(modelObservations(model, truth, cameras, 3.0), 1.0);
  ASSERT_TRUE(jumped.has_pose);
  EXPECT_TRUE(jumped.restarted);
  EXPECT_EQ(jumped.status, TrackStatus::kStarted);
  EXPECT_LT(meanFingertipError(jumped.fingertips, fingertips(model, truth)), 0.025);
}
