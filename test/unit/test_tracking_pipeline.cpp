#include <gtest/gtest.h>

#include <cmath>

#include "sag_hand_tracker/apps/metrics.h"

#include "test_support/temp_files.h"

#include "sag_hand_tracker/tracking/tracking_pipeline.h"
#include "test_support/rendered_scene.h"

using namespace sag_hand_tracker;
using namespace sag_test;

namespace {

FrameSet makeSet(int frame, const std::vector<cv::Mat>& images) {
  FrameSet set;
  set.stamp_ns = 1000000000LL + 40000000LL * frame;
  for (std::size_t i = 0; i < images.size(); ++i) {
    if (!images[i].empty()) set.images.push_back({static_cast<int>(i), images[i]});
  }
  return set;
}

std::vector<cv::Mat> deskImages(const std::vector<Camera>& cameras) {
  std::vector<cv::Mat> images;
  for (const Camera& camera : cameras) images.push_back(desk(camera));
  return images;
}

std::vector<cv::Mat> handImages(const HandModel& model, const Pose& pose,
                                const std::vector<Camera>& cameras) {
  std::vector<cv::Mat> images;
  for (const Camera& camera : cameras) images.push_back(renderHand(model, pose, camera));
  return images;
}

}  // namespace

TEST(Pipeline, PipelineLearnsTheBackgroundThenTracks) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = renderedRig();
  PipelineParams params;
  params.background_frames = 2;
  TrackingPipeline pipeline(model, cameras, params);
  EXPECT_EQ(pipeline.params().segmentation.background.frames, 2);

  for (int frame = 0; frame < 2; ++frame) {
    const ProcessedFrame processed = pipeline.process(makeSet(frame, deskImages(cameras)));
    EXPECT_TRUE(processed.background);
    EXPECT_FALSE(processed.result.has_pose);
    EXPECT_EQ(processed.result.status, TrackStatus::kWaiting);
    EXPECT_EQ(processed.image_gaussians, 0);
  }
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(pipeline.segmenter(i).backgroundFrameCount(), 2);
    EXPECT_TRUE(pipeline.segmenter(i).backgroundReady());
    EXPECT_EQ(pipeline.segmenter(i).effectiveMode(), SegmentationMode::kPlate);
  }

  // The first frame with the hand: found without an initial pose.
  const Pose truth = typicalPose(model);
  const ProcessedFrame first = pipeline.process(makeSet(2, handImages(model, truth, cameras)));
  EXPECT_FALSE(first.background);
  ASSERT_TRUE(first.result.has_pose);
  EXPECT_EQ(first.result.status, TrackStatus::kStarted);
  EXPECT_EQ(first.result.num_cameras, 4);
  EXPECT_NEAR(first.result.stamp, 1.08, 1e-9);
  EXPECT_GT(first.image_gaussians, 40);
  EXPECT_GT(first.segmentation_seconds, 0.0);
  EXPECT_GT(first.tracking_seconds, 0.0);
  EXPECT_LT(meanFingertipError(first.result.fingertips, fingertips(model, truth)), 0.03);

  // A set with a camera missing is tracked with the cameras present.
  Pose moved = truth;
  moved.translation.x() += 0.004;
  std::vector<cv::Mat> three = handImages(model, moved, cameras);
  three[1] = cv::Mat();
  const ProcessedFrame next = pipeline.process(makeSet(3, three));
  ASSERT_TRUE(next.result.has_pose);
  EXPECT_EQ(next.result.status, TrackStatus::kTracking);
  EXPECT_EQ(next.result.num_cameras, 3);
  EXPECT_LT(meanFingertipError(next.result.fingertips, fingertips(model, moved)), 0.03);
  EXPECT_EQ(pipeline.setsSeen(), 4);

  pipeline.reset();
  EXPECT_EQ(pipeline.setsSeen(), 0);
  EXPECT_EQ(pipeline.segmenter(0).backgroundFrameCount(), 0);
  EXPECT_TRUE(pipeline.process(makeSet(4, deskImages(cameras))).background);
}

TEST(Pipeline, PipelineWithoutBackgroundFramesTracksFromTheFirstSet) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = renderedRig();
  PipelineParams params;
  params.background_frames = 0;
  TrackingPipeline pipeline(model, cameras, params);
  EXPECT_EQ(pipeline.segmenter(0).effectiveMode(), SegmentationMode::kSkin);
  const Pose truth = typicalPose(model);
  const ProcessedFrame processed = pipeline.process(makeSet(0, handImages(model, truth, cameras)));
  EXPECT_FALSE(processed.background);
  ASSERT_TRUE(processed.result.has_pose);
  EXPECT_LT(meanFingertipError(processed.result.fingertips, fingertips(model, truth)), 0.03);
}

// The curled hand's refinement (TrackerParams::curled_refine_*) runs with the plate and, until it
// is measured in the rooms, not without one (PipelineParams::curled_refine_without_plate).
TEST(Pipeline, TheCurledHandsRefinementRunsWithThePlate) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = renderedRig();
  const int iterations = TrackerParams().curled_refine_iterations;
  ASSERT_GT(iterations, 0);
  EXPECT_EQ(TrackingPipeline(model, cameras, PipelineParams())
                .tracker()
                .params()
                .curled_refine_iterations,
            iterations);
  PipelineParams skin;
  skin.background_frames = 0;
  EXPECT_EQ(TrackingPipeline(model, cameras, skin).tracker().params().curled_refine_iterations, 0);
  EXPECT_EQ(curledRefineIterations(skin, true), 0);
  skin.curled_refine_without_plate = true;
  EXPECT_EQ(TrackingPipeline(model, cameras, skin).tracker().params().curled_refine_iterations,
            iterations);
  EXPECT_EQ(curledRefineIterations(skin, true), iterations);
}

// The open finger toggles (TrackerParams::toggle_curled_flexion) run with the plate and not
// without one (PipelineParams::open_toggles_without_plate): the silhouette judges an opened finger
// by the foreground it lands on.
TEST(Pipeline, TheOpenFingerTogglesRunWithThePlate) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = renderedRig();
  const double flexion = TrackerParams().toggle_curled_flexion;
  ASSERT_TRUE(std::isfinite(flexion));
  EXPECT_EQ(
      TrackingPipeline(model, cameras, PipelineParams()).tracker().params().toggle_curled_flexion,
      flexion);
  PipelineParams skin;
  skin.background_frames = 0;
  EXPECT_TRUE(
      std::isinf(TrackingPipeline(model, cameras, skin).tracker().params().toggle_curled_flexion));
  EXPECT_TRUE(std::isinf(toggleCurledFlexion(skin, true)));
  skin.open_toggles_without_plate = true;
  EXPECT_EQ(TrackingPipeline(model, cameras, skin).tracker().params().toggle_curled_flexion,
            flexion);
  EXPECT_EQ(toggleCurledFlexion(skin, true), flexion);
}

// The model's size adaptation (TrackerParams::size_step) runs with the plate and not without one
// (PipelineParams::size_adaptation_without_plate): it reads the size off the foreground.
TEST(Pipeline, TheSizeAdaptationRunsWithThePlate) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = renderedRig();
  const double step = TrackerParams().size_step;
  ASSERT_GT(step, 0.0);
  EXPECT_EQ(TrackingPipeline(model, cameras, PipelineParams()).tracker().params().size_step, step);
  PipelineParams skin;
  skin.background_frames = 0;
  EXPECT_EQ(TrackingPipeline(model, cameras, skin).tracker().params().size_step, 0.0);
  EXPECT_EQ(sizeStep(skin, true), 0.0);
  skin.size_adaptation_without_plate = true;
  EXPECT_EQ(TrackingPipeline(model, cameras, skin).tracker().params().size_step, step);
  EXPECT_EQ(sizeStep(skin, true), step);
}

// A start is searched for again in its region (PipelineParams::redetect_in_started_region) with
// the generic skin gate, no plate and the room cues (which segment in the tracked hand's region);
// not with a plate, the user's own gate or without the cues.
TEST(Pipeline, WithTheGenericGateAStartIsSearchedAgainInItsRegion) {
  PipelineParams params;
  ASSERT_TRUE(params.redetect_in_started_region);
  EXPECT_TRUE(redetectsInStartedRegion(params, /*generic_skin_gate_without_plate=*/true,
                                       /*room_cues=*/true));
  EXPECT_FALSE(redetectsInStartedRegion(params, false, true));
  EXPECT_FALSE(redetectsInStartedRegion(params, true, false));
  params.redetect_in_started_region = false;
  EXPECT_FALSE(redetectsInStartedRegion(params, true, true));
}

// Without a plate the generic skin gate's foreground holds more than the hand: the tracker's starts
// are scored with the model's area charged (PipelineParams::skin_gate_start_area_weight); with a
// plate, or with the gate around a calibrated model's colours, the tracker's own setting stays,
// and a larger one of its own is kept.
TEST(Pipeline, TheSkinGateScoresTheStartsWithTheModelsArea) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = renderedRig();
  const double weight = PipelineParams().skin_gate_start_area_weight;
  ASSERT_GT(weight, 0.0);
  PipelineParams skin;
  skin.background_frames = 0;
  EXPECT_EQ(TrackingPipeline(model, cameras, skin).params().tracker.start_model_area_weight,
            weight);
  EXPECT_EQ(TrackingPipeline(model, cameras, skin).tracker().params().start_model_area_weight,
            weight);
  EXPECT_EQ(
      TrackingPipeline(model, cameras, PipelineParams()).params().tracker.start_model_area_weight,
      0.0);
  skin.tracker.start_model_area_weight = weight + 1.0;
  EXPECT_EQ(TrackingPipeline(model, cameras, skin).tracker().params().start_model_area_weight,
            weight + 1.0);
  skin.skin_gate_start_area_weight = 0.0;
  skin.tracker.start_model_area_weight = 0.0;
  EXPECT_EQ(TrackingPipeline(model, cameras, skin).tracker().params().start_model_area_weight, 0.0);
  skin.skin_gate_start_area_weight = weight;
  const HandModel fitted =
      loadHandModel(std::string(SAG_SOURCE_DIR) + "/test/data/default_fitted.yaml");
  ASSERT_TRUE(fitted.colours_fitted);
  const TrackingPipeline own_gate(fitted, cameras, skin);
  EXPECT_TRUE(own_gate.skinGateFromModel());
  EXPECT_EQ(own_gate.tracker().params().start_model_area_weight, 0.0);
  skin.skin_gate_from_model = false;
  EXPECT_EQ(TrackingPipeline(fitted, cameras, skin).tracker().params().start_model_area_weight,
            weight);
  skin.skin_gate_start_area_weight = -1.0;
  EXPECT_EQ(sag_test::inputErrorOf([&] { TrackingPipeline(model, cameras, skin); }),
            "skin_gate_start_area_weight must be a finite number >= 0, got -1.000000");
}

TEST(Pipeline, PipelineRejectsBadInput) {
  const HandModel model = loadHandModel(modelPath("sag"));
  std::vector<Camera> cameras = renderedRig();
  TrackingPipeline pipeline(model, cameras, PipelineParams());

  FrameSet unknown = makeSet(0, {desk(cameras[0])});
  unknown.images[0].camera = 7;
  EXPECT_EQ(sag_test::inputErrorOf([&] { pipeline.process(unknown); }),
            "image of unknown camera index 7 (4 cameras)");
  const FrameSet small = makeSet(0, {cv::Mat(120, 160, CV_8UC3, cv::Scalar(1, 2, 3))});
  EXPECT_EQ(sag_test::inputErrorOf([&] { pipeline.process(small); }),
            "camera 'cam0': image is 160x120 but its calibration says 320x240");
  EXPECT_EQ(pipeline.setsSeen(), 0);

  PipelineParams negative;
  negative.background_frames = -1;
  EXPECT_EQ(sag_test::inputErrorOf([&] { TrackingPipeline(model, cameras, negative); }),
            "background_frames must be >= 0, got -1");
  EXPECT_EQ(
      sag_test::inputErrorOf([&] { TrackingPipeline(model, {cameras[0]}, PipelineParams()); }),
      "the tracker starts from at least 2 cameras that see the hand, but there are 1");
  cameras[2].K(0, 0) = 0.0;
  EXPECT_NE(sag_test::inputErrorOf([&] {
              TrackingPipeline(model, cameras, PipelineParams());
            }).find("cam2"),
            std::string::npos);
}
