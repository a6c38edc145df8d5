// The first start's search (TrackerParams::start_kept) on a studio hand that is not the model's:
// the whole offline path (the studio's images, the background plates, the segmentation, the
// tracker's start), as track_bag and the benchmark run it.
#include <gtest/gtest.h>

#include "sag_hand_tracker/apps/metrics.h"
#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/studio/hand_shapes.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/studio/renderer.h"
#include "sag_hand_tracker/studio/sequence.h"
#include "sag_hand_tracker/tracking/tracking_pipeline.h"

using namespace sag_hand_tracker;

namespace {

const std::string kSourceDir = SAG_SOURCE_DIR;
const std::string kConfigDir = kSourceDir + "/config";

struct StartOutcome {
  FrameResult result;
  double error_mm = 0.0;      // mean fingertip error of the start
  double axis_degrees = 0.0;  // wrist -> middle knuckle direction against the truth's
};

// `wristflex` on a studio hand (`shape`), tracked with that hand's fitted model (calibrate_hand,
// test/data/<shape>_fitted.yaml): the 10 frames of empty studio go into the plates and the first
// frame with the hand starts the track.
StartOutcome firstStart(const std::string& shape, const TrackerParams& tracker) {
  const HandModel model = loadHandModel(resolveModelPath("sag", kConfigDir));
  const HandModel fitted = loadHandModel(kSourceDir + "/test/data/" + shape + "_fitted.yaml");
  const std::vector<Camera> cameras =
      loadCameraRig(studio::resolveRigPath("dexter5", kConfigDir)).cameras;
  const studio::StudioHand hand = studio::resolveHandShape(shape, kConfigDir);
  studio::SequenceParams sequence_params;
  sequence_params.shape = hand.shape;
  sequence_params.surface.skin = hand.skin;
  sequence_params.frames = sequence_params.empty_frames + 1;
  const studio::StudioSequence sequence(
      model, studio::loadMotion(studio::resolveMotionPath("wristflex", kConfigDir), model, 1),
      sequence_params);
  const studio::StudioRenderer renderer(cameras);

  PipelineParams params;
  params.tracker = tracker;
  TrackingPipeline pipeline(fitted, cameras, params);
  StartOutcome outcome;
  for (int k = 0; k < sequence.frameCount(); ++k) {
    const std::vector<studio::StudioImage> images =
        renderer.render(sequence.surfaces(k), sequence.noiseSeed(k));
    FrameSet set;
    set.stamp_ns = static_cast<std::int64_t>(k) * 40000000;
    for (size_t c = 0; c < images.size(); ++c) {
      set.images.push_back({static_cast<int>(c), images[c].rgb});
    }
    const ProcessedFrame processed = pipeline.process(set);
    if (processed.background) continue;
    outcome.result = processed.result;
    const studio::StudioFrame truth = sequence.frame(k);
    outcome.error_mm = 1000.0 * meanFingertipError(processed.result.fingertips, truth.fingertips);
    // The benchmark's reversed-hand measure (apps/metrics.h).
    outcome.axis_degrees = orientationError(processed.result.pose.rotation,
                                            processed.result.pose.translation, truth.pose.rotation,
                                            truth.pose.translation, middleKnuckleDirection(fitted))
                               .forward_deg;
  }
  return outcome;
}

// The start found the hand: near it and the right way round.
void expectTheHandFound(const StartOutcome& start) {
  ASSERT_TRUE(start.result.has_pose);
  EXPECT_EQ(start.result.status, TrackStatus::kStarted);
  EXPECT_LT(start.error_mm, 20.0);
  EXPECT_LT(start.axis_degrees, 45.0);
}

}  // namespace

// With the 4 candidates a re-detection refines, this start ended on a reversed hand (energy 0.35,
// 240 mm off; the right pose, energy 0.62, ranked fifth or lower after the coarse stage), and the
// track stayed reversed for 65 frames of the benchmark's `wristflex`. The default start_kept, 8,
// finds the hand. (Since session 15 a start that weak also searches again with the forearm,
// AWeakStartSearchesAgainWithTheBareForearm below, and with 4 candidates finds it too.)
TEST(StartSearch, TheFirstStartFindsAFlexedWristOnALargerHandWithItsFittedModel) {
  ASSERT_EQ(TrackerParams().start_kept, 8);
  const StartOutcome wide = firstStart("long_distal_large", TrackerParams());
  expectTheHandFound(wide);

  TrackerParams four;
  four.start_kept = 4;
  const StartOutcome narrow = firstStart("long_distal_large", four);
  ASSERT_TRUE(narrow.result.has_pose);
  // What the wider search buys here: printed, so that a change of the energy that lets 4 find it
  // too shows up in the log (and start_kept can be revisited) without failing the test.
  std::printf(
      "start with 4 candidates: %.1f mm, axis %.0f deg, energy %.3f; with 8: %.1f mm, "
      "axis %.0f deg, energy %.3f\n",
      narrow.error_mm, narrow.axis_degrees, narrow.result.energy.total, wide.error_mm,
      wide.axis_degrees, wide.result.energy.total);
}

// The studio's stocky hand (thick, short fingers) with its fitted model (session 15's silhouette
// score: thickness x1.215): the hand-only start took a pose 93 mm off (energy 0.40), and the test
// before the second search with the forearm, which looks only at that pose, said the forearm
// could not be bare, so `wristflex` stayed 107 mm off. A start that weak now searches again with
// the forearm (TrackerParams::forearm_start_weak_energy), where the true pose scores 0.63.
TEST(StartSearch, AWeakStartSearchesAgainWithTheBareForearm) {
  ASSERT_EQ(TrackerParams().forearm_start_weak_energy, 0.5);
  const StartOutcome start = firstStart("stocky", TrackerParams());
  expectTheHandFound(start);
  EXPECT_GT(start.result.energy.total, 0.5);

  TrackerParams test_only;
  test_only.forearm_start_weak_energy = 0.0;  // the rule before: the cheap test alone
  const StartOutcome before = firstStart("stocky", test_only);
  std::printf(
      "stocky, wristflex, first start with the fitted model: %.1f mm, energy %.3f; with the "
      "cheap test alone: %.1f mm, energy %.3f\n",
      start.error_mm, start.result.energy.total, before.error_mm, before.result.energy.total);
}
