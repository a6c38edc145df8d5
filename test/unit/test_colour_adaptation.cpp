// The model's colours learnt from the images while tracking (issue 9, colour_adaptation.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "sag_hand_tracker/apps/metrics.h"
#include "sag_hand_tracker/tracking/colour_adaptation.h"
#include "sag_hand_tracker/tracking/tracker.h"
#include "test_support/synthetic_scene.h"

using namespace sag_hand_tracker;
using namespace sag_test;

namespace {

// The two palm Gaussians of the model alone, the hand palm down, a camera straight above it.
struct PalmScene {
  HandModel model;
  Pose pose;
  Camera camera;
  PalmScene() {
    model = loadHandModel(modelPath("sag"));
    model.gaussians.resize(2);  // both on the palm bone: x in [0, 0.06] and [0.044, 0.092]
    pose = typicalPose(model);  // the palm frame at (-0.06, 0, 0.15), back of the hand up (+z)
    camera = lookAtCamera("top", Eigen::Vector3d(-0.01, 0.0, 0.6), Eigen::Vector3d(-0.01, 0, 0.15));
  }
  // An image Gaussian at the palm point (x, 0, 0) of the palm frame.
  ImageGaussian at(double x, const Hsv& colour) const {
    Eigen::Vector2d pixel;
    EXPECT_TRUE(
        camera.project(pose.translation + pose.rotation * Eigen::Vector3d(x, 0, 0), &pixel));
    return {pixel, 2.0, colour};
  }
};

double hueDistance(double a, double b) {
  const double d = std::fmod(std::abs(a - b), 360.0);
  return std::min(d, 360.0 - d);
}

}  // namespace

TEST(ColourAdaptation, EachGaussianLearnsTheColourOfTheImageItAloneCovers) {
  const PalmScene scene;
  CameraObservation observation{scene.camera, ImageSoG()};
  observation.sog.gaussians = {scene.at(0.01, Hsv(10, 0.5, 0.6)),    // the first Gaussian only
                               scene.at(0.085, Hsv(40, 0.3, 0.9)),   // the second only
                               scene.at(0.25, Hsv(200, 0.9, 0.9))};  // neither: not the hand's
  GaussianColourStatistics statistics(2);
  statistics.add(scene.model, scene.pose, {observation});
  ASSERT_TRUE(statistics.mean(0) && statistics.mean(1));
  EXPECT_TRUE(statistics.mean(0)->isApprox(Hsv(10, 0.5, 0.6), 1e-9))
      << statistics.mean(0)->transpose();
  EXPECT_TRUE(statistics.mean(1)->isApprox(Hsv(40, 0.3, 0.9), 1e-9))
      << statistics.mean(1)->transpose();
  EXPECT_DOUBLE_EQ(statistics.weight(0), 4.0);  // sigma^2 of the one region
  EXPECT_DOUBLE_EQ(statistics.weight(1), 4.0);

  // Forgetting scales the area, not the colour.
  statistics.scale(0.5);
  EXPECT_DOUBLE_EQ(statistics.weight(0), 2.0);
  EXPECT_TRUE(statistics.mean(0)->isApprox(Hsv(10, 0.5, 0.6), 1e-9));
}

TEST(ColourAdaptation, TheGaussianNearestToTheCameraTakesTheRegion) {
  PalmScene scene;
  // A copy of the first Gaussian 2 cm nearer the camera (over the back of the hand).
  scene.model.gaussians[1] = scene.model.gaussians[0];
  scene.model.gaussians[1].mean.z() += 0.02;
  CameraObservation observation{scene.camera, ImageSoG()};
  observation.sog.gaussians = {scene.at(0.03, Hsv(90, 0.5, 0.5))};
  GaussianColourStatistics statistics(2);
  statistics.add(scene.model, scene.pose, {observation});
  EXPECT_FALSE(statistics.mean(0).has_value());
  ASSERT_TRUE(statistics.mean(1).has_value());
  EXPECT_NEAR((*statistics.mean(1))[0], 90.0, 1e-9);
}

TEST(ColourAdaptation, HueIsAveragedOnTheCircle) {
  GaussianColourStatistics statistics(3);
  statistics.addSample(0, Hsv(350, 0.4, 0.6), 1.0);
  statistics.addSample(0, Hsv(10, 0.6, 0.8), 1.0);
  ASSERT_TRUE(statistics.mean(0).has_value());
  EXPECT_LT(hueDistance((*statistics.mean(0))[0], 0.0), 1e-9);  // not 180
  EXPECT_NEAR((*statistics.mean(0))[1], 0.5, 1e-12);
  EXPECT_NEAR((*statistics.mean(0))[2], 0.7, 1e-12);
  // Regions that cannot count: NaN colour, no area.
  statistics.addSample(1, Hsv(std::nan(""), 0.5, 0.5), 1.0);
  statistics.addSample(1, Hsv(30, 0.5, 0.5), 0.0);
  statistics.addSample(7, Hsv(30, 0.5, 0.5), 1.0);  // no such Gaussian
  EXPECT_FALSE(statistics.mean(1).has_value());
  EXPECT_EQ(statistics.weight(1), 0.0);
  // Pooled: the area-weighted mean of the members.
  statistics.addSample(2, Hsv(30, 0.2, 0.2), 2.0);
  double weight = 0.0;
  const std::optional<Hsv> pooled = statistics.pooledMean({0, 1, 2}, &weight);
  ASSERT_TRUE(pooled.has_value());
  EXPECT_DOUBLE_EQ(weight, 4.0);
  EXPECT_NEAR((*pooled)[1], (0.4 + 0.6 + 2 * 0.2) / 4.0, 1e-12);
}

TEST(ColourAdaptation, PalmGaussiansEachTheirOwnFingersOneTogether) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const size_t n = model.gaussians.size();
  ASSERT_EQ(model.gaussians[0].bone, 0);
  ASSERT_EQ(model.gaussians[1].bone, 0);
  ASSERT_NE(model.gaussians[2].bone, 0);
  const std::vector<Hsv> start = modelColours(model);
  GaussianColourStatistics statistics(n);
  statistics.addSample(0, Hsv(15, 0.6, 0.5), 40.0);
  // Gaussian 1 collects too little to count; two finger Gaussians collect the fingers' colour.
  statistics.addSample(1, Hsv(100, 0.1, 0.1), 0.1);
  statistics.addSample(5, Hsv(30, 0.2, 0.9), 30.0);
  statistics.addSample(9, Hsv(40, 0.4, 0.7), 30.0);
  const std::vector<Hsv> colours = adaptedColours(model, start, statistics, 0.1);
  ASSERT_EQ(colours.size(), n);
  EXPECT_TRUE(colours[0].isApprox(Hsv(15, 0.6, 0.5), 1e-9));
  EXPECT_TRUE(colours[1].isApprox(start[1], 1e-12));
  for (size_t p = 2; p < n; ++p) {
    EXPECT_LT(hueDistance(colours[p][0], 35.0), 0.5) << "Gaussian " << p;
    EXPECT_NEAR(colours[p][1], 0.3, 1e-12) << "Gaussian " << p;
    EXPECT_NEAR(colours[p][2], 0.8, 1e-12) << "Gaussian " << p;
  }
  // Fingers that were hardly seen keep the start colours.
  GaussianColourStatistics hidden_fingers(n);
  hidden_fingers.addSample(0, Hsv(15, 0.6, 0.5), 40.0);
  hidden_fingers.addSample(1, Hsv(15, 0.6, 0.5), 40.0);
  hidden_fingers.addSample(4, Hsv(30, 0.2, 0.9), 0.01);
  const std::vector<Hsv> kept = adaptedColours(model, start, hidden_fingers, 0.1);
  for (size_t p = 2; p < n; ++p) EXPECT_TRUE(kept[p].isApprox(start[p], 1e-12)) << p;
}

// The tracker, with the default model's single skin colour, tracks a hand whose palm and fingers
// have other colours: it learns them and keeps tracking; reset() forgets them, and so does
// switching the adaptation off.
TEST(ColourAdaptation, TheTrackerLearnsTheUsersColoursAndResetForgetsThem) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  HandModel user = model;
  const Hsv palm(12.0, 0.62, 0.55), fingers(32.0, 0.3, 0.85);
  for (ModelGaussian& gaussian : user.gaussians) gaussian.hsv = gaussian.bone == 0 ? palm : fingers;
  // modelImageSoG colours a pixel like the first Gaussian that covers it: the fingers first, so
  // that a finger over the palm has the finger's colour, as in a camera image.
  std::reverse(user.gaussians.begin(), user.gaussians.end());

  auto run = [&](const TrackerParams& params, double* worst) {
    HandTracker tracker(model, params);
    Pose truth = typicalPose(model);
    *worst = 0.0;
    for (int frame = 0; frame < 40; ++frame) {
      truth.translation.x() += 0.002;
      truth.joints[4] = 0.2 + 0.3 * std::sin(frame * 0.15);
      const FrameResult result =
          tracker.update(modelObservations(user, truth, cameras, 3.0), frame * 0.04);
      EXPECT_TRUE(result.has_pose) << "frame " << frame;
      if (result.has_pose && frame > 2) {
        *worst = std::max(*worst, meanFingertipError(result.fingertips, fingertips(model, truth)));
      }
    }
    return tracker;
  };

  double worst = 0.0;
  HandTracker tracker = run(TrackerParams(), &worst);
  EXPECT_LT(worst, 0.015) << "worst fingertip error " << worst * 1000 << " mm";
  const HandModel& learnt = tracker.model();
  for (size_t p = 0; p < learnt.gaussians.size(); ++p) {
    const Hsv& colour = learnt.gaussians[p].hsv;
    const Hsv& truth = learnt.gaussians[p].bone == 0 ? palm : fingers;
    EXPECT_LT(hueDistance(colour[0], truth[0]), 4.0)
        << "Gaussian " << p << ": " << colour.transpose();
    EXPECT_NEAR(colour[1], truth[1], 0.06) << "Gaussian " << p;
    EXPECT_NEAR(colour[2], truth[2], 0.06) << "Gaussian " << p;
  }
  tracker.reset();
  EXPECT_EQ(modelColours(tracker.model()), modelColours(model));

  // Switched off while tracking (the live graph's dynamic_reconfigure): the model's own colours.
  HandTracker switched = run(TrackerParams(), &worst);
  EXPECT_NE(modelColours(switched.model()), modelColours(model));
  TrackerParams off;
  off.colour_adaptation.enabled = false;
  switched.setParams(off);
  EXPECT_EQ(modelColours(switched.model()), modelColours(model));

  HandTracker fixed = run(off, &worst);
  EXPECT_EQ(modelColours(fixed.model()), modelColours(model));
}

// A model fitted to the user (calibrate_hand) keeps the colours it was fitted with.
TEST(ColourAdaptation, AFittedModelKeepsItsColours) {
  HandModel model = loadHandModel(modelPath("sag"));
  model.colours_fitted = true;
  HandModel user = model;
  for (ModelGaussian& gaussian : user.gaussians) gaussian.hsv = Hsv(35.0, 0.3, 0.6);
  HandTracker tracker(model, TrackerParams());
  Pose truth = typicalPose(model);
  for (int frame = 0; frame < 30; ++frame) {
    truth.translation.x() += 0.002;
    EXPECT_TRUE(tracker.update(modelObservations(user, truth, fiveCameraRig(), 3.0), frame * 0.04)
                    .has_pose);
  }
  EXPECT_EQ(modelColours(tracker.model()), modelColours(model));
}
