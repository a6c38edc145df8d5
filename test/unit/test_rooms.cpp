// Issue 11: real rooms. The energy on a masked studio image (no drift toward a camera), the room
// cues of the segmentation (region of interest, motion, learned skin colour, plate adaptation),
// the studio rooms and their evaluation.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <opencv2/imgproc.hpp>

#include "sag_hand_tracker/apps/room_evaluation.h"
#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/energy/energy.h"
#include "sag_hand_tracker/energy/hand_projection.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/optimization/optimizer.h"
#include "sag_hand_tracker/segmentation/multi_view_consistency.h"
#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"
#include "sag_hand_tracker/studio/hand_shapes.h"
#include "sag_hand_tracker/studio/hand_surface.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/studio/renderer.h"
#include "sag_hand_tracker/studio/room.h"
#include "sag_hand_tracker/tracking/tracker.h"
#include "sag_hand_tracker/tracking/tracking_pipeline.h"

using namespace sag_hand_tracker;
using namespace sag_hand_tracker::studio;

namespace {

const std::string kConfigDir = std::string(SAG_SOURCE_DIR) + "/config";

const HandModel& model(const std::string& name) {
  static const HandModel sag = loadHandModel(resolveModelPath("sag", kConfigDir));
  static const HandModel sog = loadHandModel(resolveModelPath("sog", kConfigDir));
  return name == "sag" ? sag : sog;
}

// The default hand's model fitted by calibrate_hand in the clean studio: its colours are the
// studio hand's (colours: fitted), as a user's calibrated model.
const HandModel& fittedDefaultModel() {
  static const HandModel fitted =
      loadHandModel(std::string(SAG_SOURCE_DIR) + "/test/data/default_fitted.yaml");
  return fitted;
}

const std::vector<Camera>& dexter5() {
  static const std::vector<Camera> cameras =
      loadCameraRig(kConfigDir + "/rigs/dexter5/rig.yaml").cameras;
  return cameras;
}

Pose studioPose() {
  const Motion motion =
      loadMotion(resolveMotionPath("pinch", kConfigDir), model("sag"), /*seed=*/1);
  return motion.poseAt(2.0);
}

// The studio's hand at `pose` in every dexter5 camera, masked to the hand by the label image
// (everything else black), as skin-gated image SoGs: a real-like image with perfect segmentation.
// `refine_border_pixels` as in SegmentationParams (default: the border decided pixel by pixel).
std::vector<CameraObservation> maskedStudioObservations(const Pose& pose,
                                                        bool refine_border_pixels = true) {
  static const StudioRenderer renderer(dexter5());
  const PosedHand posed = forwardKinematics(model("sag"), pose);
  const auto parts = buildHandSurface(model("sag"), posed.bone_frames, HandSurfaceParams());
  const auto images = renderer.render({parts}, 7);
  SegmentationParams params;
  params.mode = SegmentationMode::kSkin;
  params.refine_border_pixels = refine_border_pixels;
  const ImageSegmenter segmenter(params);
  std::vector<CameraObservation> observations;
  for (size_t c = 0; c < images.size(); ++c) {
    cv::Mat masked = images[c].rgb.clone();
    for (int i = 0; i < static_cast<int>(masked.total()); ++i) {
      if (!isTrackedHandLabel(images[c].labels.data[i]))
        masked.at<cv::Vec3b>(i) = cv::Vec3b(0, 0, 0);
    }
    CameraObservation observation;
    observation.camera = dexter5()[c];
    observation.sog = segmenter.segment(masked);
    observations.push_back(observation);
  }
  return observations;
}

struct Drift {
  double wrist_mm = 0.0;           // distance of the fitted wrist from the true one
  double closest_camera_mm = 0.0;  // how much closer than the truth the fit is to any camera
};

// Fits from `start` on the masked studio image of `truth` (many frames' worth of iterations).
Drift fit(const std::string& model_name, double model_area_weight,
          const std::vector<CameraObservation>& observations, const Pose& truth,
          const Pose& start) {
  EnergyParams energy_params;
  energy_params.model_area_weight = model_area_weight;
  PoseEnergy energy(model(model_name), energy_params);
  energy.setFrame(observations);
  OptimizerParams optimizer;
  optimizer.iterations = 100;
  // Both models share the skeleton, so the true pose is a pose of either.
  const OptimizationResult fitted = optimizePose(energy, start, optimizer);
  Drift drift;
  drift.wrist_mm = 1000.0 * (fitted.pose.translation - truth.translation).norm();
  for (const Camera& camera : dexter5()) {
    const double before = (camera.centre() - truth.translation).norm();
    const double after = (camera.centre() - fitted.pose.translation).norm();
    drift.closest_camera_mm = std::max(drift.closest_camera_mm, 1000.0 * (before - after));
  }
  return drift;
}

}  // namespace

// Fitted on a perfectly masked studio image, from the true pose and from a start 4 cm closer to
// camera 0, neither model ends up closer to a camera than the hand is (issue 11: on real images
// the SoG model drifted toward one camera while its energy rose).
TEST(EnergyCannotCheat, FitsOnAMaskedStudioImageDoNotDriftTowardACamera) {
  const Pose truth = studioPose();
  const std::vector<CameraObservation> observations = maskedStudioObservations(truth);
  Pose closer = truth;
  closer.translation += 0.04 * (dexter5()[0].centre() - truth.translation).normalized();
  for (const std::string name : {"sag", "sog"}) {
    for (const bool from_truth : {true, false}) {
      const Pose& start = from_truth ? truth : closer;
      const Drift paper = fit(name, 0.0, observations, truth, start);
      const Drift ours = fit(name, 1.0, observations, truth, start);
      std::printf(
          "%s from %s: paper normalisation: wrist %.1f mm off, %.1f mm closer to a "
          "camera; model area: wrist %.1f mm off, %.1f mm closer\n",
          name.c_str(), from_truth ? "the truth" : "4 cm toward cam0", paper.wrist_mm,
          paper.closest_camera_mm, ours.wrist_mm, ours.closest_camera_mm);
      EXPECT_LT(ours.closest_camera_mm, 10.0) << name;
      EXPECT_LT(ours.wrist_mm, 20.0) << name;
    }
  }
}

namespace {

// Mean fingertip distance (mm) of the fit from `truth` after 40 iterations (four frames' worth).
double fingertipDriftFromTruth(const EnergyParams& params,
                               const std::vector<CameraObservation>& observations,
                               const Pose& truth) {
  PoseEnergy energy(model("sag"), params);
  energy.setFrame(observations);
  OptimizerParams optimizer;
  optimizer.iterations = 40;
  const Pose fitted = optimizePose(energy, truth, optimizer).pose;
  const Fingertips a = fingertips(model("sag"), fitted), b = fingertips(model("sag"), truth);
  double sum = 0.0;
  for (int f = 0; f < kNumFingers; ++f) sum += (a[f] - b[f]).norm();
  return 1000.0 * sum / kNumFingers;
}

}  // namespace

// Issue 9 (curled fingers): with eq. 8's cap alone a finger curled over the palm earns nothing
// there and loses nothing when it straightens onto an edge, so fits from the true fist drift
// open. Occlusion (EnergyParams::occlusion_depth_scale) with the model's visible area in the
// normalisation (model_area_weight) makes a straight finger over the background cost what a
// hidden one does not: fits from the truth on fists of `fingercount` drift less than half as far
// (measured 22.1 -> 10.7 mm on the whole-cell image SoG this was measured on in session 11), and
// on open hands they stay close (measured 4.5-5.1 mm). With the silhouette's border decided pixel
// by pixel (session 19's default) the gain is smaller, 18.4 -> 12.3 mm (doc/history.md, session
// 19): there the test asks only that occlusion still helps.
TEST(EnergyCannotCheat, WithOcclusionAndTheModelAreaFistsStayClosed) {
  EnergyParams paper;
  EnergyParams occluding;
  occluding.occlusion_depth_scale = 0.005;
  occluding.model_area_weight = 1.0;
  const Motion fists = loadMotion(resolveMotionPath("fingercount", kConfigDir), model("sag"), 1);
  for (const bool refine_border_pixels : {false, true}) {
    double paper_drift = 0.0, occluding_drift = 0.0;
    for (const double time : {1.5, 6.48, 8.46, 9.5}) {
      const Pose truth = fists.poseAt(time);
      const std::vector<CameraObservation> observations =
          maskedStudioObservations(truth, refine_border_pixels);
      paper_drift += 0.25 * fingertipDriftFromTruth(paper, observations, truth);
      occluding_drift += 0.25 * fingertipDriftFromTruth(occluding, observations, truth);
    }
    std::printf(
        "fists (%s): fingertips drift %.1f mm (paper's energy), %.1f mm (occlusion, area)\n",
        refine_border_pixels ? "border pixel by pixel" : "whole cells", paper_drift,
        occluding_drift);
    EXPECT_LT(occluding_drift, (refine_border_pixels ? 1.0 : 0.6) * paper_drift);
  }
  const Motion open = loadMotion(resolveMotionPath("adbadd", kConfigDir), model("sag"), 1);
  for (const double time : {1.0, 2.0}) {
    const Pose truth = open.poseAt(time);
    const double drift = fingertipDriftFromTruth(occluding, maskedStudioObservations(truth), truth);
    EXPECT_LT(drift, 8.0) << "adbadd at " << time << " s";
  }
}

// Issue 9 (curled fingers, TrackerParams::curled_refine_*): in the clean studio, a hand that
// closes into fists is tracked closer with the curled hand's refinement (root and thumb held,
// occlusion and the model's area) than without it, and than with the same refinement scored by
// the paper's energy. Measured (default hand, 200 frames): `flexex1` 11.5 mm refined, 16.6
// without, 12.4 with the paper's energy; `fingercount` 12.3, 15.3, 22.1.
TEST(StudioRooms, CurledRefinementTracksFistsCloser) {
  double refined_sum = 0.0, paper_sum = 0.0;
  for (const std::string sequence : {"flexex1", "fingercount"}) {
    const Motion motion = loadMotion(resolveMotionPath(sequence, kConfigDir), model("sag"), 1);
    RoomSequenceOptions options;
    options.frames = 200;
    RoomRunConfig refined{"refined", model("sag"), PipelineParams()};
    ASSERT_GT(refined.pipeline.tracker.curled_refine_iterations, 0);
    // The refinement alone, as it was measured: the size adaptation (session 41) moves all three
    // tracks (with it: flexex1 10.5 mm refined, 12.3 without, 15.4 with the paper's energy).
    refined.pipeline.tracker.size_step = 0.0;
    RoomRunConfig without = refined;
    without.label = "without";
    without.pipeline.tracker.curled_refine_iterations = 0;
    RoomRunConfig paper = refined;
    paper.label = "the paper's energy";
    paper.pipeline.tracker.curled_refine_model_area_weight = 0.0;
    paper.pipeline.tracker.curled_refine_occlusion_depth_scale = 0.0;
    const auto results = evaluateRoomSequence(model("sag"), dexter5(), motion, nullptr, kConfigDir,
                                              {refined, without, paper}, options);
    ASSERT_EQ(results.size(), 3u);
    std::printf(
        "%s, clean studio: %.1f mm refined, %.1f mm without, %.1f mm with the paper's energy\n",
        sequence.c_str(), results[0].errors.mean_mm, results[1].errors.mean_mm,
        results[2].errors.mean_mm);
    for (const RoomRunResult& r : results) EXPECT_EQ(r.frames_posed, r.frames) << r.label;
    EXPECT_LT(results[0].errors.mean_mm, 0.85 * results[1].errors.mean_mm) << sequence;
    refined_sum += results[0].errors.mean_mm;
    paper_sum += results[2].errors.mean_mm;
  }
  EXPECT_LT(refined_sum, 0.85 * paper_sum);
}

// ---- room cues
// ------------------------------------------------------------------------------------

namespace {

const cv::Vec3b kGrey(118, 120, 126);
const cv::Vec3b kSkin(200, 140, 110);
const cv::Vec3b kWood(160, 100, 50);  // passes the generic skin gate, other chromaticity

cv::Mat greyImage(double gain = 1.0) {
  return cv::Mat(240, 320, CV_8UC3, cv::Scalar(kGrey[0] * gain, kGrey[1] * gain, kGrey[2] * gain));
}
void disc(cv::Mat& image, cv::Point centre, int radius, cv::Vec3b colour) {
  cv::circle(image, centre, radius, cv::Scalar(colour[0], colour[1], colour[2]), cv::FILLED);
}
unsigned char maskAt(const ImageSegmenter& segmenter, cv::Point p) {
  return segmenter.lastForegroundMask().at<unsigned char>(p);
}
SegmentationParams roomSkinParams() {
  SegmentationParams params;
  params.mode = SegmentationMode::kSkin;
  params.room.enabled = true;
  return params;
}

}  // namespace

TEST(RoomCues, RegionOfInterestKeepsOnlyTheHandsSide) {
  ImageSegmenter segmenter(roomSkinParams());
  cv::Mat image = greyImage();
  disc(image, {90, 120}, 25, kSkin);   // the hand
  disc(image, {240, 120}, 30, kSkin);  // a face
  segmenter.setRegionOfInterest(cv::Rect(50, 80, 80, 80));
  const ImageSoG sog = segmenter.segmentFrame(image);
  EXPECT_EQ(maskAt(segmenter, {90, 120}), 255);
  EXPECT_EQ(maskAt(segmenter, {240, 120}), 0);
  for (const ImageGaussian& g : sog.gaussians) EXPECT_LT(g.mean.x(), 130.0);
  // Without the room cues the same call keeps both.
  SegmentationParams plain = roomSkinParams();
  plain.room.enabled = false;
  ImageSegmenter plain_segmenter(plain);
  plain_segmenter.setRegionOfInterest(cv::Rect(50, 80, 80, 80));
  plain_segmenter.segmentFrame(image);
  EXPECT_EQ(maskAt(plain_segmenter, {240, 120}), 255);
}

// Without a plate the sleeve beside the hand is the forearm evidence the plate would give
// (ImageSoG::arm_cells): the dark cells next to the kept skin, when they lie to one side of it.
TEST(RoomCues, WithoutAPlateTheSleeveBesideTheHandIsTheForearmEvidence) {
  const cv::Mat light(240, 320, CV_8UC3, cv::Scalar(200, 205, 210));
  cv::Mat image = light.clone();
  cv::rectangle(image, cv::Rect(0, 105, 120, 30), cv::Scalar(20, 20, 24), cv::FILLED);  // sleeve
  cv::rectangle(image, cv::Rect(120, 100, 70, 40), cv::Scalar(200, 140, 110), cv::FILLED);
  ImageSegmenter segmenter(roomSkinParams());
  const ImageSoG sog = segmenter.segmentFrame(image);
  ASSERT_GT(sog.arm_cells, 6);
  EXPECT_LT(sog.arm_centroid.x(), 120.0);  // on the sleeve's side of the hand
  EXPECT_NEAR(sog.arm_centroid.y(), 120.0, 8.0);
  // Only the band next to the hand counts (4 cells of 4 px), not the whole sleeve.
  EXPECT_GT(sog.arm_centroid.x(), 95.0);
  ASSERT_EQ(sog.arm_gaussians.size(), static_cast<size_t>(sog.arm_cells));
  for (const ImageGaussian& g : sog.arm_gaussians) {
    EXPECT_GT(g.mean.x(), 100.0);  // the band's cells (4 of 4 px), on the sleeve
    EXPECT_LT(g.mean.x(), 120.0);
    EXPECT_GT(g.mean.y(), 100.0);
    EXPECT_LT(g.mean.y(), 140.0);
  }

  // The same for a part of the foreground given as a mask (a still hypothesis' blob), and the
  // sleeve of another blob is not this one's.
  cv::Mat two = image.clone();
  cv::rectangle(two, cv::Rect(230, 30, 60, 40), cv::Scalar(200, 140, 110), cv::FILLED);
  cv::rectangle(two, cv::Rect(230, 70, 60, 60), cv::Scalar(20, 20, 24), cv::FILLED);
  cv::Mat first_blob(240, 320, CV_8UC1, cv::Scalar(0));
  first_blob(cv::Rect(120, 100, 70, 40)).setTo(255);
  ImageSoG evidence;
  segmenter.segmentFrame(two);
  segmenter.sleeveEvidence(first_blob, &evidence);
  EXPECT_GT(evidence.arm_cells, 6);
  EXPECT_LT(evidence.arm_centroid.x(), 120.0);
  EXPECT_EQ(evidence.arm_gaussians.size(), static_cast<size_t>(evidence.arm_cells));
  EXPECT_THROW(segmenter.sleeveEvidence(cv::Mat(10, 10, CV_8UC1), &evidence), InputError);

  // Dark all around the hand (a shadow, a dark table) says nothing about the wrist.
  cv::Mat ring = light.clone();
  cv::rectangle(ring, cv::Rect(100, 80, 110, 80), cv::Scalar(20, 20, 24), cv::FILLED);
  cv::rectangle(ring, cv::Rect(120, 100, 70, 40), cv::Scalar(200, 140, 110), cv::FILLED);
  ImageSegmenter ring_segmenter(roomSkinParams());
  EXPECT_EQ(ring_segmenter.segmentFrame(ring).arm_cells, 0);

  // Off: no evidence without a plate, as before.
  SegmentationParams off = roomSkinParams();
  off.room.sleeve_band_cells = 0;
  ImageSegmenter off_segmenter(off);
  EXPECT_EQ(off_segmenter.segmentFrame(image).arm_cells, 0);
  off.room.sleeve_min_offset = -1.0;
  EXPECT_THROW(ImageSegmenter{off}, InputError);
}

TEST(RoomCues, WithoutARegionTheMovingComponentWins) {
  ImageSegmenter segmenter(roomSkinParams());
  cv::Mat first = greyImage();
  disc(first, {90, 120}, 22, kSkin);   // the hand, smaller
  disc(first, {240, 120}, 32, kSkin);  // a still face, larger
  segmenter.segmentFrame(first);
  // First frame: nothing has moved yet, the larger blob wins (one component only).
  EXPECT_EQ(maskAt(segmenter, {240, 120}), 255);
  EXPECT_EQ(maskAt(segmenter, {90, 120}), 0);
  cv::Mat second = greyImage();
  disc(second, {102, 126}, 22, kSkin);  // the hand moved
  disc(second, {240, 120}, 32, kSkin);
  segmenter.segmentFrame(second);
  EXPECT_EQ(maskAt(segmenter, {102, 126}), 255);
  EXPECT_EQ(maskAt(segmenter, {240, 120}), 0);
}

TEST(RoomCues, ChangingLightIsNotMotion) {
  ImageSegmenter segmenter(roomSkinParams());
  cv::Mat first = greyImage();
  disc(first, {90, 120}, 22, kSkin);
  disc(first, {240, 120}, 32, kSkin);
  segmenter.segmentFrame(first);
  // The whole scene dims by 25 % and the small blob moves: only the small blob moves, so it wins
  // over the larger one although every pixel changed (were the dimming motion, the larger blob
  // would move everywhere and win).
  cv::Mat second = greyImage(0.75);
  disc(second, {102, 126}, 22, cv::Vec3b(150, 105, 82));
  disc(second, {240, 120}, 32, cv::Vec3b(150, 105, 82));
  segmenter.segmentFrame(second);
  EXPECT_EQ(maskAt(segmenter, {102, 126}), 255);
  EXPECT_EQ(maskAt(segmenter, {240, 120}), 0);
}

TEST(RoomCues, LearnedSkinColourRejectsWoodThatTheGatePasses) {
  ImageSegmenter segmenter(roomSkinParams());
  cv::Mat image = greyImage();
  disc(image, {100, 120}, 25, kSkin);
  disc(image, {170, 120}, 20, kWood);
  // The hand is found: its region covers the hand only; the skin colour is learned from it.
  segmenter.setRegionOfInterest(cv::Rect(60, 80, 80, 80));
  segmenter.segmentFrame(image);
  EXPECT_TRUE(segmenter.skinColourLearned());
  // A region that also covers the wood: the wood is not the user's skin.
  segmenter.setRegionOfInterest(cv::Rect(60, 80, 150, 80));
  segmenter.segmentFrame(image);
  EXPECT_EQ(maskAt(segmenter, {100, 120}), 255);
  EXPECT_EQ(maskAt(segmenter, {170, 120}), 0);
  // The generic gate alone passes the wood.
  EXPECT_TRUE(isSkinColour(Eigen::Vector3d(kWood[0], kWood[1], kWood[2]), SkinParams()));
}

// Dark skin over a grey table: a cell on the hand's outline holds both, and its chromaticity lies
// between the skin's and grey's, far from the learned skin's (the studio's dark_small hand lost its
// fingertips and tracked its index finger curled, doc/segmentation.md "Session 32"). Such cells
// are kept where they touch the hand; wood beside the hand, and a blob of the mixed colour apart
// from it, are not.
TEST(RoomCues, DarkSkinsOutlineOverGreyIsKeptOnceTheSkinIsLearned) {
  const cv::Vec3b dark_skin(96, 66, 50);
  const cv::Vec3b mixed((dark_skin[0] + kGrey[0]) / 2, (dark_skin[1] + kGrey[1]) / 2,
                        (dark_skin[2] + kGrey[2]) / 2);
  ASSERT_TRUE(
      isSkinColour(Eigen::Vector3d(dark_skin[0], dark_skin[1], dark_skin[2]), SkinParams()));
  ASSERT_TRUE(isSkinColour(Eigen::Vector3d(mixed[0], mixed[1], mixed[2]), SkinParams()));
  cv::Mat image = greyImage();
  const cv::Point hand(100, 121);
  disc(image, hand, 25, dark_skin);
  // A finger 6 pixels wide, across the 4-pixel cells: its edge cells are half skin, half grey.
  cv::rectangle(image, cv::Point(124, 118), cv::Point(165, 123),
                cv::Scalar(dark_skin[0], dark_skin[1], dark_skin[2]), cv::FILLED);
  disc(image, {100, 161}, 13, kWood);  // touches the hand
  disc(image, {220, 60}, 14, mixed);   // the outline's colour, apart from the hand
  cv::Mat hand_pixels(image.size(), CV_8UC1, cv::Scalar(0));
  cv::circle(hand_pixels, hand, 25, cv::Scalar(255), cv::FILLED);
  cv::rectangle(hand_pixels, cv::Point(124, 118), cv::Point(165, 123), cv::Scalar(255), cv::FILLED);

  auto keptHandShare = [&](double neutral_share) {
    SegmentationParams params = roomSkinParams();
    params.room.skin_border_neutral_share = neutral_share;
    ImageSegmenter segmenter(params);
    // The hand is found: its region covers the disc's inside only; the skin is learned there.
    segmenter.setRegionOfInterest(cv::Rect(80, 101, 40, 40));
    segmenter.segmentFrame(image);
    EXPECT_TRUE(segmenter.skinColourLearned());
    segmenter.setRegionOfInterest(cv::Rect(0, 0, 320, 240));
    segmenter.segmentFrame(image);
    const cv::Mat mask = segmenter.lastForegroundMask();
    EXPECT_EQ(maskAt(segmenter, {100, 170}), 0) << "wood, share " << neutral_share;
    EXPECT_EQ(maskAt(segmenter, {220, 60}), 0) << "mixed apart, share " << neutral_share;
    return static_cast<double>(cv::countNonZero(mask & hand_pixels)) /
           cv::countNonZero(hand_pixels);
  };
  const double without = keptHandShare(0.0), with = keptHandShare(0.6);
  EXPECT_GT(with, 0.97);
  EXPECT_LT(without, 0.92);  // the outline lost
}

// The user's skin gate (personalSkinGate) from a calibrated model's colours: the skin in light and
// in shade passes, the wood that the generic gate passes does not (its saturation is above the
// hand's), and so does not a blue or a grey.
TEST(RoomCues, TheUsersSkinGateKeepsShadedSkinAndDropsWood) {
  ASSERT_TRUE(fittedDefaultModel().colours_fitted);
  const SkinParams gate = personalSkinGate(fittedDefaultModel());
  auto passes = [&](const cv::Vec3b& c, const SkinParams& params) {
    return isSkinColour(Eigen::Vector3d(c[0], c[1], c[2]), params);
  };
  for (const double shade : {1.0, 0.7, 0.45}) {
    const cv::Vec3b skin(kSkin[0] * shade, kSkin[1] * shade, kSkin[2] * shade);
    EXPECT_TRUE(passes(skin, gate)) << shade;
  }
  EXPECT_TRUE(passes(kWood, SkinParams()));
  EXPECT_FALSE(passes(kWood, gate));
  EXPECT_FALSE(passes(kGrey, gate));
  EXPECT_FALSE(passes(cv::Vec3b(60, 90, 200), gate));
  // Darker than the margin allows (a sleeve's shadow, hair).
  EXPECT_FALSE(passes(cv::Vec3b(kSkin[0] / 5, kSkin[1] / 5, kSkin[2] / 5), gate));
}

// Hues on both sides of 0/360 (a pink hand under reddish light) make one range around 0.
TEST(RoomCues, TheUsersSkinGateWrapsAroundRed) {
  const SkinParams gate = personalSkinGate(std::vector<Hsv>{{355.0, 0.4, 0.7}, {5.0, 0.4, 0.7}});
  EXPECT_NEAR(gate.hue_max_deg - gate.hue_min_deg, 10.0 + 2 * 12.0, 1e-9);
  EXPECT_TRUE(isSkinColour(Eigen::Vector3d(200, 120, 120), gate));   // hue 0
  EXPECT_TRUE(isSkinColour(Eigen::Vector3d(200, 120, 140), gate));   // hue 345
  EXPECT_FALSE(isSkinColour(Eigen::Vector3d(200, 160, 120), gate));  // hue 30
  EXPECT_FALSE(isSkinColour(Eigen::Vector3d(200, 120, 190), gate));  // hue 307
}

TEST(RoomCues, TheUsersSkinGateRefusesWhatIsNoColour) {
  EXPECT_THROW(personalSkinGate(std::vector<Hsv>{}), InputError);
  try {
    personalSkinGate(std::vector<Hsv>{{20.0, 0.4, 0.7}, {20.0, 1.5, 0.7}});
    ADD_FAILURE() << "a saturation of 1.5 was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("colour 1"), std::string::npos) << e.what();
  }
  EXPECT_THROW(personalSkinGate(std::vector<Hsv>{{NAN, 0.4, 0.7}}), InputError);
  // Colours of a blue-grey desk (a fit that sampled the background): no skin gate from them.
  try {
    personalSkinGate(std::vector<Hsv>{{216.0, 0.36, 0.55}, {20.0, 0.4, 0.7}, {210.0, 0.3, 0.5}});
    ADD_FAILURE() << "a gate from a desk's colours";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("only 1 of 3 colours are skin-coloured"),
              std::string::npos)
        << e.what();
  }
  PersonalSkinGateParams negative;
  negative.hue_margin_deg = -1.0;
  EXPECT_THROW(personalSkinGate(std::vector<Hsv>{{20.0, 0.4, 0.7}}, negative), InputError);
}

// forgetTrackedHand drops the colour learned from a track (here, the wood taken for the hand by a
// region that covered both) and with it that colour's rejection of other things.
TEST(RoomCues, ForgettingTheTrackedHandForgetsItsColour) {
  ImageSegmenter segmenter(roomSkinParams());
  cv::Mat image = greyImage();
  disc(image, {100, 120}, 25, kSkin);
  disc(image, {170, 120}, 20, kWood);
  segmenter.setRegionOfInterest(cv::Rect(60, 80, 80, 80));  // the hand
  segmenter.segmentFrame(image);
  ASSERT_TRUE(segmenter.skinColourLearned());
  segmenter.setRegionOfInterest(cv::Rect(60, 80, 150, 80));
  segmenter.segmentFrame(image);
  ASSERT_EQ(maskAt(segmenter, {170, 120}), 0);  // the learned colour drops the wood
  segmenter.forgetTrackedHand();
  EXPECT_FALSE(segmenter.skinColourLearned());
  cv::Mat both(image.rows, image.cols, CV_8UC1, cv::Scalar(0));
  both(cv::Rect(60, 80, 150, 80)).setTo(255);
  segmenter.setRegionOfInterest(both, RegionSource::kCandidates);  // learns nothing
  segmenter.segmentFrame(image);
  EXPECT_EQ(maskAt(segmenter, {170, 120}), 255);  // the generic gate alone keeps it again
  EXPECT_EQ(maskAt(segmenter, {100, 120}), 255);
}

TEST(RoomCues, TheHandsColourAgainstTheBackgroundsDropsAPhotographTouchingTheHand) {
  // A photograph's skin tone: passes the generic gate and is near the user's skin (the learned
  // chromaticity test is widened here so that only cue 6 can separate them), but its chromaticity
  // lies three histogram bins from the hand's.
  const cv::Vec3b kPortrait(215, 130, 95);
  ASSERT_TRUE(
      isSkinColour(Eigen::Vector3d(kPortrait[0], kPortrait[1], kPortrait[2]), SkinParams()));
  cv::Mat image = greyImage();
  disc(image, {100, 120}, 25, kSkin);      // the hand
  disc(image, {240, 120}, 25, kPortrait);  // the photograph away from the hand
  disc(image, {133, 120}, 8, kPortrait);   // and where it touches the hand
  cv::Mat region(image.rows, image.cols, CV_8UC1, cv::Scalar(0));
  cv::circle(region, {100, 120}, 35, cv::Scalar(255), cv::FILLED);  // the model, grown by 10 px
  for (const double ratio : {1.0, 0.0}) {
    SegmentationParams params = roomSkinParams();
    params.room.skin_max_distance = 10.0;
    params.room.colour_ratio = ratio;
    ImageSegmenter segmenter(params);
    for (int k = 0; k < 3; ++k) {
      segmenter.setRegionOfInterest(region, RegionSource::kTrack);
      segmenter.segmentFrame(image);
    }
    EXPECT_EQ(maskAt(segmenter, {100, 120}), 255) << "ratio " << ratio;  // the hand's core
    EXPECT_EQ(maskAt(segmenter, {122, 120}), 255)
        << "ratio " << ratio;                                          // its edge, not in the core
    EXPECT_EQ(maskAt(segmenter, {240, 120}), 0) << "ratio " << ratio;  // outside the region
    // The part of the photograph inside the region: dropped by its colour, kept without cue 6.
    EXPECT_EQ(maskAt(segmenter, {131, 120}), ratio > 0.0 ? 0 : 255) << "ratio " << ratio;
  }
  // A region of candidates (before the start) learns nothing: the photograph stays.
  SegmentationParams params = roomSkinParams();
  params.room.skin_max_distance = 10.0;
  ImageSegmenter segmenter(params);
  for (int k = 0; k < 3; ++k) {
    segmenter.setRegionOfInterest(region, RegionSource::kCandidates);
    segmenter.segmentFrame(image);
  }
  EXPECT_EQ(maskAt(segmenter, {131, 120}), 255);
}

// Cue 7: without a plate, a skin-coloured thing that touches the hand inside the region (a ball
// at the fingertips) and stays still outside the model's own silhouette is dropped after
// still_object_frames frames; the hand under the model and a part of it that moves stay.
TEST(RoomCues, AStillSkinObjectBesideTheModelIsDroppedOnceItHasStayedStill) {
  const cv::Vec3b kSkinDarker(180, 126, 99);  // the same chromaticity, 10 % darker
  cv::Mat region(240, 320, CV_8UC1, cv::Scalar(0));
  cv::circle(region, {100, 120}, 60, cv::Scalar(255), cv::FILLED);  // holds hand and ball
  cv::Mat silhouette(240, 320, CV_8UC1, cv::Scalar(0));
  cv::circle(silhouette, {100, 120}, 27, cv::Scalar(255), cv::FILLED);  // the model: the hand
  const cv::Point hand(100, 120), ball(140, 120), finger(100, 75);
  auto image = [&](int frame) {
    cv::Mat rgb = greyImage();
    disc(rgb, hand, 25, kSkin);
    disc(rgb, ball, 14, kSkin);  // touches the hand, the hand's own colour
    // A finger outside the model that moves: its colour changes every frame.
    cv::rectangle(rgb, cv::Rect(94, 70, 12, 30),
                  frame % 2 ? cv::Scalar(kSkin[0], kSkin[1], kSkin[2])
                            : cv::Scalar(kSkinDarker[0], kSkinDarker[1], kSkinDarker[2]),
                  cv::FILLED);
    return rgb;
  };
  SegmentationParams params = roomSkinParams();
  ASSERT_EQ(params.room.still_object_frames, 25);
  params.room.still_object_frames = 5;
  ImageSegmenter segmenter(params);
  for (int frame = 1; frame <= 8; ++frame) {
    segmenter.setRegionOfInterest(region, RegionSource::kTrack, silhouette);
    segmenter.segmentFrame(image(frame));
    EXPECT_EQ(maskAt(segmenter, hand), 255) << "frame " << frame;
    EXPECT_EQ(maskAt(segmenter, finger), 255) << "frame " << frame;
    EXPECT_EQ(maskAt(segmenter, ball), frame < 5 ? 255 : 0) << "frame " << frame;
  }
  // Once the model covers it, it is kept again at once (the count starts again under the model).
  cv::Mat wider = silhouette.clone();
  cv::circle(wider, ball, 16, cv::Scalar(255), cv::FILLED);
  segmenter.setRegionOfInterest(region, RegionSource::kTrack, wider);
  segmenter.segmentFrame(image(9));
  EXPECT_EQ(maskAt(segmenter, ball), 255);

  // A set without the model (a restart: candidates only) neither counts nor forgets: counted
  // frames 1-3, the gap, then 4 and 5; dropped from the fifth counted frame on, not 5 frames
  // after the gap.
  {
    ImageSegmenter gap(params);
    for (int frame = 1; frame <= 7; ++frame) {
      gap.setRegionOfInterest(region, frame == 4 ? RegionSource::kCandidates : RegionSource::kTrack,
                              silhouette);
      gap.segmentFrame(image(frame));
      if (frame == 4) continue;
      EXPECT_EQ(maskAt(gap, hand), 255) << "frame " << frame;
      EXPECT_EQ(maskAt(gap, ball), frame < 6 ? 255 : 0) << "frame " << frame;
    }
  }

  // Off (0), with a region of candidates, or without the model's silhouette: the ball stays.
  for (const int variant : {0, 1, 2}) {
    SegmentationParams p = roomSkinParams();
    if (variant == 0) p.room.still_object_frames = 0;
    ImageSegmenter s(p);
    for (int frame = 1; frame <= 30; ++frame) {
      if (variant == 1) {
        s.setRegionOfInterest(region, RegionSource::kCandidates, silhouette);
      } else {
        s.setRegionOfInterest(region, RegionSource::kTrack, variant == 2 ? cv::Mat() : silhouette);
      }
      s.segmentFrame(image(frame));
    }
    EXPECT_EQ(maskAt(s, ball), 255) << "variant " << variant;
  }
  // A silhouette of another size or type is refused, naming it.
  try {
    segmenter.setRegionOfInterest(region, RegionSource::kTrack, cv::Mat(10, 10, CV_8UC1));
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("silhouette"), std::string::npos) << e.what();
  }
}

// Cue 8 (doc/segmentation.md, "Session 21"): a skin-coloured ball that lay unchanged beside the
// place where the hand then came into view is dropped at the start and for as long as it stays
// unchanged, even once the model covers it and after the hand has held still for longer than
// cue 7's count, through dimming light and a shadow; the hand is kept. A hand that was there as
// still as the ball from the first frame (a still start) is kept, and so is the ball then.
TEST(RoomCues, WhatLayUnchangedBeforeTheHandCameIsDroppedEvenUnderTheModel) {
  const cv::Point hand(100, 120), ball(138, 120);
  cv::Mat region(240, 320, CV_8UC1, cv::Scalar(0));
  cv::circle(region, hand, 60, cv::Scalar(255), cv::FILLED);  // holds hand and ball
  // The model has crept onto the ball: its silhouette covers both.
  cv::Mat silhouette(240, 320, CV_8UC1, cv::Scalar(0));
  cv::circle(silhouette, hand, 27, cv::Scalar(255), cv::FILLED);
  cv::circle(silhouette, ball, 16, cv::Scalar(255), cv::FILLED);
  // light: the scene's brightness; shadow: the ball's own, as if the hand's shadow fell on it.
  auto image = [&](bool with_hand, double light, double shadow) {
    cv::Mat rgb = greyImage(light);
    const cv::Vec3b skin(kSkin[0] * light, kSkin[1] * light, kSkin[2] * light);
    disc(rgb, ball, 14,
         cv::Vec3b(skin[0] * shadow, skin[1] * shadow, skin[2] * shadow));  // the hand's colour
    if (with_hand) disc(rgb, hand, 25, skin);
    return rgb;
  };
  SegmentationParams params = roomSkinParams();
  ASSERT_TRUE(params.room.drop_older_than_hand);
  ASSERT_EQ(params.room.still_object_frames, 25);
  for (const bool cue : {true, false}) {
    params.room.drop_older_than_hand = cue;
    ImageSegmenter segmenter(params);
    // Frames 1-6: the ball alone, nothing tracked.
    for (int frame = 1; frame <= 6; ++frame) segmenter.segmentFrame(image(false, 1.0, 1.0));
    // Frame 7: the hand comes into view touching the ball; the start's region holds both.
    segmenter.setRegionOfInterest(region, RegionSource::kCandidates);
    segmenter.segmentFrame(image(true, 1.0, 1.0));
    EXPECT_EQ(maskAt(segmenter, hand), 255) << "start, cue " << cue;
    EXPECT_EQ(maskAt(segmenter, ball), cue ? 0 : 255) << "start, cue " << cue;
    // Frames 8-47: tracked; the hand holds perfectly still for 40 frames under the model, the
    // light dims by 30 % and the ball is shaded by 30 % in every other frame.
    for (int frame = 8; frame <= 47; ++frame) {
      segmenter.setRegionOfInterest(region, RegionSource::kTrack, silhouette);
      const double light = 1.0 - 0.3 * (frame - 8) / 39.0;
      segmenter.segmentFrame(image(true, light, frame % 2 ? 0.7 : 1.0));
      EXPECT_EQ(maskAt(segmenter, hand), 255) << "frame " << frame << ", cue " << cue;
      // Without the cue the ball under the model counts as hand for ever (cue 7 starts again
      // under the model): the loop of session 20.
      EXPECT_EQ(maskAt(segmenter, ball), cue ? 0 : 255) << "frame " << frame << ", cue " << cue;
    }
  }

  // A hand held still from the first frame beside the ball (a still start): as old as the ball,
  // both kept (cue 7 off, which would drop the ball outside the model).
  params = roomSkinParams();
  params.room.still_object_frames = 0;
  ImageSegmenter still(params);
  for (int frame = 1; frame <= 6; ++frame) still.segmentFrame(image(true, 1.0, 1.0));
  still.setRegionOfInterest(region, RegionSource::kCandidates);
  still.segmentFrame(image(true, 1.0, 1.0));
  EXPECT_EQ(maskAt(still, hand), 255);
  EXPECT_EQ(maskAt(still, ball), 255);
  for (int frame = 8; frame <= 40; ++frame) {
    still.setRegionOfInterest(region, RegionSource::kTrack, silhouette);
    still.segmentFrame(image(true, 1.0, 1.0));
  }
  EXPECT_EQ(maskAt(still, hand), 255);
  EXPECT_EQ(maskAt(still, ball), 255);

  // With a plate the cue is off (a plate holds still things already).
  EXPECT_FALSE(ImageSegmenter(SegmentationParams()).usesModelSilhouette());
}

// Cue 8 with a hand in view from the first frame (doc/segmentation.md, "Session 50"; the
// studio's kitchen): the palm holds still while the fingers move. The moving fingers alone would
// set the age quantile, and the palm, unchanged since the first frame like the room around it,
// was dropped at the start and for the whole track (kitchen pinch 57 mm). Most of the hand has
// not changed since the first frame, so nothing that old is dropped under a track; at the start
// only what lies within first_frame_hand_reach_cells of the moving fingers is kept (the start's
// blob can hold a table joined with the hand), so the ball, as old as the hand and farther, goes
// then, and comes back under the track (cue 8 cannot tell it from the palm). With
// first_frame_hand_share above 1 (off) the palm goes.
TEST(RoomCues, AHandInViewFromTheFirstFrameKeepsItsStillPalm) {
  const cv::Point palm(100, 120), palm_by_the_fingers(100, 140), ball(165, 180);
  // The fingers move between two places beside the palm, never overlapping.
  const cv::Point fingers[2] = {cv::Point(145, 120), cv::Point(100, 165)};
  cv::Mat region(240, 320, CV_8UC1, cv::Scalar(0));
  cv::circle(region, palm, 100, cv::Scalar(255), cv::FILLED);  // palm, fingers and ball
  cv::Mat silhouette(240, 320, CV_8UC1, cv::Scalar(0));
  cv::circle(silhouette, palm, 27, cv::Scalar(255), cv::FILLED);
  for (const cv::Point& f : fingers) cv::circle(silhouette, f, 20, cv::Scalar(255), cv::FILLED);
  auto image = [&](int frame) {
    cv::Mat rgb = greyImage();
    disc(rgb, ball, 14, kSkin);
    disc(rgb, palm, 25, kSkin);
    disc(rgb, fingers[frame % 2], 18, kSkin);
    return rgb;
  };
  ASSERT_EQ(SegmentationParams().room.first_frame_hand_share, 0.5);
  ASSERT_EQ(SegmentationParams().room.first_frame_hand_reach_cells, 4);
  for (const auto& [share, reach] : {std::pair<double, int>{0.5, 4}, {0.5, 0}, {2.0, 4}}) {
    const bool on = share <= 1.0;
    SegmentationParams params = roomSkinParams();
    params.room.first_frame_hand_share = share;
    params.room.first_frame_hand_reach_cells = reach;
    params.room.still_object_frames = 0;  // cue 7 would drop the ball outside the model
    ImageSegmenter segmenter(params);
    const std::string name = "share " + std::to_string(share) + ", reach " + std::to_string(reach);
    // Frames 1-6: nothing tracked; frame 7: the start's region holds palm, fingers and ball.
    for (int frame = 1; frame <= 6; ++frame) segmenter.segmentFrame(image(frame));
    segmenter.setRegionOfInterest(region, RegionSource::kCandidates);
    segmenter.segmentFrame(image(7));
    EXPECT_EQ(maskAt(segmenter, fingers[1]), 255) << "start, " << name;
    EXPECT_EQ(maskAt(segmenter, palm_by_the_fingers), on ? 255 : 0) << "start, " << name;
    EXPECT_EQ(maskAt(segmenter, palm), on && reach == 0 ? 255 : 0) << "start, " << name;
    EXPECT_EQ(maskAt(segmenter, ball), on && reach == 0 ? 255 : 0) << "start, " << name;
    // Frames 8-47: tracked, the model over palm and fingers.
    for (int frame = 8; frame <= 47; ++frame) {
      segmenter.setRegionOfInterest(region, RegionSource::kTrack, silhouette);
      segmenter.segmentFrame(image(frame));
      EXPECT_EQ(maskAt(segmenter, fingers[frame % 2]), 255) << "frame " << frame << ", " << name;
      EXPECT_EQ(maskAt(segmenter, palm), on ? 255 : 0) << "frame " << frame << ", " << name;
      EXPECT_EQ(maskAt(segmenter, ball), on ? 255 : 0) << "frame " << frame << ", " << name;
    }
  }
}

// The model's own silhouette (cue 7) lies inside the region of interest, covers the rendered
// hand, and is much tighter than the region; nothing behind the camera.
TEST(RoomCues, TheModelSilhouetteCoversTheRenderedHandInsideTheRegion) {
  const Pose pose = studioPose();
  const PosedHand posed = forwardKinematics(model("sag"), pose);
  static const StudioRenderer renderer(dexter5());
  const auto images =
      renderer.render({buildHandSurface(model("sag"), posed.bone_frames, HandSurfaceParams())}, 3);
  for (size_t c = 0; c < dexter5().size(); ++c) {
    const Camera& camera = dexter5()[c];
    const cv::Mat silhouette = projectedModelSilhouette(posed, camera);
    const cv::Mat region = projectedHandMask(posed, camera);
    int hand = 0, covered = 0;
    for (int i = 0; i < static_cast<int>(images[c].labels.total()); ++i) {
      if (!isTrackedHandLabel(images[c].labels.data[i])) continue;
      ++hand;
      covered += silhouette.data[i] != 0;
    }
    ASSERT_GT(hand, 500) << camera.name;
    EXPECT_GT(covered, 0.97 * hand) << camera.name;
    EXPECT_EQ(cv::countNonZero(silhouette & ~region), 0) << camera.name;
    EXPECT_LT(cv::countNonZero(silhouette), 0.6 * cv::countNonZero(region)) << camera.name;
    std::printf("%s: the silhouette covers %.1f %% of the hand, %.0f %% of the region's area\n",
                camera.name.c_str(), 100.0 * covered / hand,
                100.0 * cv::countNonZero(silhouette) / cv::countNonZero(region));
  }
  Pose behind = pose;
  const Camera& camera = dexter5()[0];
  behind.translation = camera.centre() + 0.3 * (camera.centre() - pose.translation).normalized();
  EXPECT_EQ(
      cv::countNonZero(projectedModelSilhouette(forwardKinematics(model("sag"), behind), camera)),
      0);
}

TEST(RoomCues, ThePlateFollowsTheLightWhereTheHandIsNot) {
  SegmentationParams params;
  params.mode = SegmentationMode::kPlate;
  params.room.enabled = true;
  ImageSegmenter segmenter(params);
  for (int k = 0; k < params.background.frames; ++k) segmenter.addBackgroundFrame(greyImage());
  ASSERT_TRUE(segmenter.backgroundReady());
  // The room brightens by 20 %: beyond the plate's tolerance, and no shadow.
  cv::Mat image = greyImage(1.2);
  disc(image, {100, 120}, 25, kSkin);
  segmenter.setRegionOfInterest(cv::Rect(60, 80, 80, 80));
  for (int k = 0; k < 60; ++k) segmenter.segmentFrame(image);
  const cv::Mat plate = segmenter.backgroundPlate().mean();
  const cv::Vec3f far = plate.at<cv::Vec3f>(10, 60);    // cell of pixel (240, 40)
  const cv::Vec3f under = plate.at<cv::Vec3f>(30, 25);  // cell of pixel (100, 120): the hand
  EXPECT_NEAR(far[0], 1.2 * kGrey[0], 3.0);             // followed the light
  EXPECT_NEAR(under[0], kGrey[0], 1.0);                 // not learned where the hand is
  // With the region cleared, the brighter room is background and the (moving) hand foreground.
  segmenter.setRegionOfInterest(cv::Rect());
  cv::Mat moved = greyImage(1.2);
  disc(moved, {110, 126}, 25, kSkin);
  segmenter.segmentFrame(moved);
  EXPECT_EQ(maskAt(segmenter, {240, 40}), 0);
  EXPECT_EQ(maskAt(segmenter, {110, 126}), 255);
}

TEST(RoomCues, BadParametersAreNamed) {
  // `change` makes the default parameters bad; the error names `name`.
  auto expectNamed = [](const std::function<void(RoomCueParams&)>& change, const std::string& name,
                        const std::string& what) {
    SegmentationParams params;
    change(params.room);
    try {
      validate(params);
      ADD_FAILURE() << what << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("room." + name), std::string::npos) << e.what();
    }
  };
  expectNamed([](RoomCueParams& r) { r.motion_decay = 1.0; }, "motion_decay", "motion_decay 1");
  expectNamed(
      [](RoomCueParams& r) { r.colour_rim_depth = r.colour_core_depth; },  // rim reaches core
      "colour_core_depth", "colour_rim_depth == colour_core_depth");
  expectNamed([](RoomCueParams& r) { r.still_object_frames = -1; }, "still_object_frames",
              "still_object_frames -1");
  SegmentationParams split;
  split.room.split_candidate_share = 1.5;
  EXPECT_THROW(validate(split), InputError);
  split = SegmentationParams();
  split.room.split_margin_cells = -1;
  EXPECT_THROW(validate(split), InputError);
  // Every change of brightness would be a change.
  expectNamed([](RoomCueParams& r) { r.unchanged_brightness = 1.0; }, "unchanged_brightness",
              "unchanged_brightness 1");
  expectNamed([](RoomCueParams& r) { r.older_quantile = 1.5; }, "older_quantile",
              "older_quantile 1.5");
  expectNamed([](RoomCueParams& r) { r.first_frame_hand_share = -0.1; }, "first_frame_hand_share",
              "first_frame_hand_share -0.1");
  expectNamed([](RoomCueParams& r) { r.first_frame_hand_reach_cells = -1; },
              "first_frame_hand_reach_cells", "first_frame_hand_reach_cells -1");
}

TEST(RoomCues, ProjectedHandBoxCoversTheHandAndIsEmptyBehindTheCamera) {
  const Pose pose = studioPose();
  const PosedHand posed = forwardKinematics(model("sag"), pose);
  for (const Camera& camera : dexter5()) {
    const cv::Rect box = projectedHandBox(model("sag"), pose, camera, 0.0, 0);
    ASSERT_GT(box.area(), 0) << camera.name;
    for (const WorldGaussian& g : posed.gaussians) {
      Eigen::Vector2d pixel;
      ASSERT_TRUE(camera.project(g.mean, &pixel));
      if (pixel.x() < 0 || pixel.y() < 0 || pixel.x() >= camera.width || pixel.y() >= camera.height)
        continue;
      EXPECT_TRUE(box.contains(cv::Point(static_cast<int>(pixel.x()), static_cast<int>(pixel.y()))))
          << camera.name;
    }
  }
  Pose behind = pose;
  const Camera& camera = dexter5()[0];
  behind.translation = camera.centre() + 0.3 * (camera.centre() - pose.translation).normalized();
  EXPECT_EQ(projectedHandBox(model("sag"), behind, camera).area(), 0);
}

TEST(RoomCues, HandCandidatesAreRankedAndLeaveTheMemoryAlone) {
  ImageSegmenter segmenter(roomSkinParams());
  cv::Mat image = greyImage();
  disc(image, {90, 120}, 22, kSkin);   // the hand, smaller
  disc(image, {240, 120}, 32, kSkin);  // a face, larger
  const std::vector<HandCandidate> candidates = segmenter.handCandidates(image, 4);
  ASSERT_EQ(candidates.size(), 2u);
  EXPECT_GT(candidates[0].score, candidates[1].score);
  EXPECT_NEAR(candidates[0].centroid.x(), 240.0, 3.0);  // larger, nothing moved yet
  EXPECT_NEAR(candidates[1].centroid.x(), 90.0, 3.0);
  EXPECT_TRUE(candidates[1].box.contains(cv::Point(90, 120)));
  EXPECT_EQ(segmenter.handCandidates(image, 1).size(), 1u);
  // Asking changed nothing: no motion history, so the first segmentFrame still sees no motion.
  segmenter.segmentFrame(image);
  EXPECT_EQ(maskAt(segmenter, {240, 120}), 255);
  EXPECT_EQ(maskAt(segmenter, {90, 120}), 0);
  // After the hand moved it leads the candidates.
  cv::Mat moved = greyImage();
  disc(moved, {102, 126}, 22, kSkin);
  disc(moved, {240, 120}, 32, kSkin);
  const std::vector<HandCandidate> after = segmenter.handCandidates(moved, 4);
  ASSERT_EQ(after.size(), 2u);
  EXPECT_NEAR(after[0].centroid.x(), 102.0, 3.0);
  // Off without the room cues.
  SegmentationParams plain = roomSkinParams();
  plain.room.enabled = false;
  EXPECT_TRUE(ImageSegmenter(plain).handCandidates(image, 4).empty());
}

// Cue 9 (RoomCueParams::split_candidate_share): a hand that lies on a table of skin colour is one
// blob with it, far larger than a hand, whose centroid is the table's. Once the hand moves, the
// blob also offers the part around its moving cells, centred on the hand.
TEST(RoomCues, AHandOnASkinColouredTableIsACandidateOfItsOwnWhenItMoves) {
  auto scene = [](cv::Point hand) {
    cv::Mat image = greyImage();
    cv::rectangle(image, cv::Rect(0, 140, 320, 100), cv::Scalar(kWood[0], kWood[1], kWood[2]),
                  cv::FILLED);     // the table: 42 % of the image
    disc(image, hand, 22, kSkin);  // the hand, resting on its edge
    return image;
  };
  for (const double share : {0.15, 0.0}) {
    SegmentationParams params = roomSkinParams();
    params.room.split_candidate_share = share;
    ImageSegmenter segmenter(params);
    segmenter.segmentFrame(scene({150, 130}));
    const std::vector<HandCandidate> candidates = segmenter.handCandidates(scene({158, 126}), 4);
    ASSERT_GE(candidates.size(), 1u);
    EXPECT_GT(candidates[0].centroid.y(), 160.0);  // the table and the hand: the table's centre
    if (share > 0.0) {
      ASSERT_EQ(candidates.size(), 2u);
      // Its cells within 6 cells of the moving ones: the hand and a band of the table below it.
      const Eigen::Vector2d hand(158.0, 126.0);
      EXPECT_LT((candidates[1].centroid - hand).norm(), 25.0);  // within the hand's radius
      EXPECT_LT((candidates[1].centroid - hand).norm(),
                0.5 * (candidates[0].centroid - hand).norm());
      EXPECT_GT(candidates[1].moving, 0);
      EXPECT_LT(candidates[1].cell_indices.size(), candidates[0].cell_indices.size() / 3);
    } else {
      EXPECT_EQ(candidates.size(), 1u);
    }
  }
  // Nothing moves: no part of its own.
  ImageSegmenter still(roomSkinParams());
  still.segmentFrame(scene({150, 130}));
  EXPECT_EQ(still.handCandidates(scene({150, 130}), 4).size(), 1u);
}

TEST(RoomCues, CandidateRegionKeepsTheChosenBlobAndAnEmptyOneKeepsNothing) {
  ImageSegmenter segmenter(roomSkinParams());
  cv::Mat image = greyImage();
  disc(image, {90, 120}, 22, kSkin);
  disc(image, {240, 120}, 32, kSkin);
  const std::vector<HandCandidate> candidates = segmenter.handCandidates(image, 4);
  ASSERT_EQ(candidates.size(), 2u);
  const cv::Mat region = candidateRegion(&candidates[1], image.cols, image.rows, 2);
  EXPECT_EQ(region.at<unsigned char>(120, 90), 255);
  EXPECT_EQ(region.at<unsigned char>(120, 90 - 22 - 6), 255);  // grown by two 4-pixel cells
  EXPECT_EQ(region.at<unsigned char>(120, 240), 0);
  segmenter.setRegionOfInterest(region, RegionSource::kCandidates);
  segmenter.segmentFrame(image);
  EXPECT_EQ(maskAt(segmenter, {90, 120}), 255);
  EXPECT_EQ(maskAt(segmenter, {240, 120}), 0);
  // A candidate region is no tracked hand: the user's skin colour is not learned from it.
  EXPECT_FALSE(segmenter.skinColourLearned());
  // No candidate of this view agreed with the others: nothing is foreground.
  segmenter.setRegionOfInterest(candidateRegion(nullptr, image.cols, image.rows, 2),
                                RegionSource::kCandidates);
  segmenter.segmentFrame(image);
  EXPECT_EQ(cv::countNonZero(segmenter.lastForegroundMask()), 0);
  // The same all-zero mask from a track (the hand outside this view) clears the region instead,
  // as before.
  segmenter.setRegionOfInterest(candidateRegion(nullptr, image.cols, image.rows, 2));
  EXPECT_EQ(segmenter.regionOfInterest().area(), 0);
}

namespace {

// A candidate of 100 cells at a root-frame point's projection in `camera`, `moving` of them moving.
HandCandidate candidateAt(const Camera& camera, const Eigen::Vector3d& point, double score,
                          int moving = 50) {
  Eigen::Vector2d pixel;
  EXPECT_TRUE(camera.project(point, &pixel));
  HandCandidate candidate;
  candidate.centroid = pixel;
  candidate.score = score;
  candidate.cell_indices.assign(100, 0);
  candidate.cell_size = 4;  // 1600 pixels: a hand's size (0.003-0.007 m^2) at dexter5's depths
  candidate.moving = moving;
  candidate.box =
      cv::Rect(static_cast<int>(pixel.x()) - 20, static_cast<int>(pixel.y()) - 20, 40, 40);
  return candidate;
}

}  // namespace

TEST(MultiViewConsistency, TheBlobsThatTriangulateAreTheHandNotTheLargerFace) {
  const std::vector<Camera>& cameras = dexter5();
  const Eigen::Vector3d hand = studioPose().translation;
  std::vector<std::vector<HandCandidate>> candidates(cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c) {
    candidates[c].push_back(candidateAt(cameras[c], hand, 100.0));
  }
  // A face at the edge of camera 1 that scores better there, and one in camera 3 that lies 25 cm
  // to the side of the hand (along the camera's x axis).
  HandCandidate face;
  face.centroid = Eigen::Vector2d(10.0, 20.0);
  face.score = 500.0;
  face.cell_indices.assign(500, 0);
  face.moving = 100;
  candidates[1].insert(candidates[1].begin(), face);
  candidates[3].insert(
      candidates[3].begin(),
      candidateAt(cameras[3], hand + 0.25 * cameras[3].world_to_camera.linear().row(0).transpose(),
                  400.0));
  const MultiViewChoice choice = chooseConsistentCandidates(cameras, candidates, MultiViewParams());
  ASSERT_TRUE(choice.found);
  EXPECT_EQ(choice.supporting_views, static_cast<int>(cameras.size()));
  EXPECT_LT((choice.point - hand).norm(), 0.005);
  EXPECT_EQ(choice.chosen[1], 1);
  EXPECT_EQ(choice.chosen[3], 1);
  for (size_t c = 0; c < cameras.size(); ++c) {
    EXPECT_NEAR(candidates[c][choice.chosen[c]].score, 100.0, 1e-9) << c;
  }
}

namespace {

// A still head 30 cm behind and 20 cm above the studio hand: its candidate (`score`, no cell
// moving) in every dexter5 view that sees it.
std::vector<std::vector<HandCandidate>> stillHeadCandidates(double score) {
  const std::vector<Camera>& cameras = dexter5();
  const Eigen::Vector3d head = studioPose().translation + Eigen::Vector3d(0.0, -0.3, 0.2);
  std::vector<std::vector<HandCandidate>> candidates(cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c) {
    Eigen::Vector2d pixel;
    if (cameras[c].project(head, &pixel)) {
      candidates[c].push_back(candidateAt(cameras[c], head, score, /*moving=*/0));
    }
  }
  return candidates;
}

}  // namespace

TEST(MultiViewConsistency, AStillObjectSeenByEveryViewCannotStartTheTrack) {
  const std::vector<Camera>& cameras = dexter5();
  const Eigen::Vector3d hand = studioPose().translation;
  std::vector<std::vector<HandCandidate>> candidates = stillHeadCandidates(400.0);
  // Only the head: it triangulates, but it does not move.
  EXPECT_FALSE(chooseConsistentCandidates(cameras, candidates, MultiViewParams()).found);
  MultiViewParams no_motion;
  no_motion.min_moving_share = 0.0;
  EXPECT_TRUE(chooseConsistentCandidates(cameras, candidates, no_motion).found);
  // The hand, moving in two views only (a share of 5 % is too little elsewhere).
  for (size_t c = 0; c < cameras.size(); ++c) {
    candidates[c].push_back(candidateAt(cameras[c], hand, 100.0, c < 2 ? 40 : 5));
  }
  const MultiViewChoice choice = chooseConsistentCandidates(cameras, candidates, MultiViewParams());
  ASSERT_TRUE(choice.found);
  EXPECT_LT((choice.point - hand).norm(), 0.005);
  EXPECT_EQ(choice.supporting_views, static_cast<int>(cameras.size()));  // all views support it
}

TEST(MultiViewConsistency, AHandThatComesIntoViewReplacesATrackOnTheOtherArm) {
  const std::vector<Camera>& cameras = dexter5();
  const Eigen::Vector3d hand = studioPose().translation;
  const Eigen::Vector3d other_arm = hand + Eigen::Vector3d(0.35, -0.1, -0.1);
  std::vector<std::vector<HandCandidate>> candidates(cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c) {
    // The other arm drifts (some cells move) and is seen by four views; the hand has just come
    // into view in all five (every cell moved).
    Eigen::Vector2d pixel;
    if (c != 0 && cameras[c].project(other_arm, &pixel)) {
      candidates[c].push_back(candidateAt(cameras[c], other_arm, 300.0, 30));
    }
    candidates[c].push_back(candidateAt(cameras[c], hand, 200.0, 100));
  }
  const MultiViewParams params;
  const MultiViewChoice challenger = chooseConsistentCandidates(cameras, candidates, params);
  ASSERT_TRUE(challenger.found);
  EXPECT_LT((challenger.point - hand).norm(), 0.005);
  const MultiViewChoice at_arm = supportAt(cameras, candidates, other_arm, params);
  EXPECT_FALSE(at_arm.found);
  EXPECT_LE(at_arm.supporting_views, 4);
  EXPECT_GE(at_arm.supporting_views, 2);
  EXPECT_TRUE(replacesTrack(challenger, at_arm, params));
  // A track on the hand is not replaced by the choice at the hand itself, nor by the arm.
  const MultiViewChoice at_hand = supportAt(cameras, candidates, hand, params);
  EXPECT_EQ(at_hand.supporting_views, static_cast<int>(cameras.size()));
  EXPECT_FALSE(replacesTrack(challenger, at_hand, params));
  MultiViewChoice arm_choice = at_arm;
  arm_choice.found = true;
  EXPECT_FALSE(replacesTrack(arm_choice, at_hand, params));
}

// The kitchen (doc/segmentation.md, "Session 23"): the tracked hand lies on a skin-coloured table,
// so in most views its candidate is one blob of hand and table whose centroid is far from the
// hand. Those views still see the hand where the track is: the blob covers its projection. The
// other arm, drifting in two views, must not take the track for having more views that agree on
// a centroid.
TEST(MultiViewConsistency, ATrackOnAHandMergedWithTheTableKeepsTheViewsThatSeeIt) {
  const std::vector<Camera>& cameras = dexter5();
  const Eigen::Vector3d hand = studioPose().translation;
  const Eigen::Vector3d other_arm = hand + Eigen::Vector3d(0.35, -0.1, -0.1);
  const int cell_size = 4;
  // A blob of 11 x 30 cells that starts `gap` cells beside the hand's projection and reaches away
  // from it toward the wider side of the image: its centroid is at least 15 cells (60 pixels) from
  // the hand, beyond the support radius (5 cm at the hand's depth: 20-40 pixels in dexter5).
  auto tableBlob = [&](const Camera& camera, const Eigen::Vector3d& at, int gap) {
    Eigen::Vector2d pixel;
    EXPECT_TRUE(camera.projectDistorted(at, &pixel));
    HandCandidate blob;
    blob.cell_size = cell_size;
    blob.cells_x = camera.width / cell_size;
    const int cx = static_cast<int>(pixel.x()) / cell_size;
    const int cy = static_cast<int>(pixel.y()) / cell_size;
    const int first = 2 * cx < blob.cells_x ? cx + gap : cx - gap - 29;
    for (int y = cy - 5; y <= cy + 5; ++y) {
      for (int x = first; x < first + 30; ++x) blob.cell_indices.push_back(y * blob.cells_x + x);
    }
    EXPECT_GE(first, 0);
    EXPECT_LE(first + 30, blob.cells_x);  // no cell wraps into the next row
    blob.centroid = Eigen::Vector2d((first + 15) * cell_size, (cy + 0.5) * cell_size);
    blob.score = static_cast<double>(blob.cell_indices.size());
    blob.moving = 20;
    return blob;
  };
  // The hand is a candidate of its own in camera 0 only; the arm moves in cameras 1 and 2.
  auto scene = [&](int gap) {
    std::vector<std::vector<HandCandidate>> candidates(cameras.size());
    for (size_t c = 0; c < cameras.size(); ++c) {
      candidates[c].push_back(c == 0 ? candidateAt(cameras[c], hand, 200.0, 20)
                                     : tableBlob(cameras[c], hand, gap));
      if (c == 1 || c == 2) candidates[c].push_back(candidateAt(cameras[c], other_arm, 300.0, 45));
    }
    return candidates;
  };
  const std::vector<std::vector<HandCandidate>> candidates = scene(0);
  const MultiViewParams params;
  const MultiViewChoice at_hand = supportAt(cameras, candidates, hand, params);
  EXPECT_EQ(at_hand.supporting_views, static_cast<int>(cameras.size()));
  EXPECT_EQ(at_hand.moving, 100);
  MultiViewChoice arm_choice = supportAt(cameras, candidates, other_arm, params);
  EXPECT_EQ(arm_choice.supporting_views, 2);
  arm_choice.found = true;
  EXPECT_FALSE(replacesTrack(arm_choice, at_hand, params));
  // Blobs that end 3 cells short of the hand's projection do not see it: only camera 0 supports
  // the track, and the arm takes it.
  const MultiViewChoice beside = supportAt(cameras, scene(3), hand, params);
  EXPECT_EQ(beside.supporting_views, 1);
  EXPECT_TRUE(replacesTrack(arm_choice, beside, params));
}

// The kitchen's re-check (doc/segmentation.md, "Session 49"): in every view the user's hand is one
// blob with the table or a wall photograph that also reaches the other arm, on which the track
// is. The user's fingers move at the blob's far end: they are not the track's moving cells.
TEST(MultiViewConsistency, ATrackCountsOnlyTheMovingCellsNearIt) {
  const std::vector<Camera>& cameras = dexter5();
  const Eigen::Vector3d hand = studioPose().translation;
  const Eigen::Vector3d other_arm = hand + Eigen::Vector3d(0.25, -0.05, 0.0);
  const int cell_size = 4;
  std::vector<std::vector<HandCandidate>> candidates(cameras.size());
  int total_moving = 0, views = 0;
  for (size_t c = 0; c < cameras.size(); ++c) {
    Eigen::Vector2d at_hand, at_arm;
    const Eigen::AlignedBox2d image(Eigen::Vector2d::Zero(),
                                    Eigen::Vector2d(cameras[c].width - 1, cameras[c].height - 1));
    if (!cameras[c].projectDistorted(hand, &at_hand) ||
        !cameras[c].projectDistorted(other_arm, &at_arm) || !image.contains(at_hand) ||
        !image.contains(at_arm)) {
      continue;  // a view that does not see both
    }
    // Only views where the user's moving fingers (within 3 cells of the hand's projection) lie
    // beyond moving_reach around the arm's projection (the default, 12 cm at the arm's depth).
    const double reach_pixels = cameras[c].K(0, 0) * MultiViewParams().moving_reach /
                                (cameras[c].world_to_camera * other_arm).z();
    if ((at_hand - at_arm).norm() < reach_pixels + 5 * cell_size) continue;
    ++views;
    // One blob over the box of both projections (grown by 3 cells), its cells within 3 cells of
    // the hand's projection moving.
    HandCandidate blob;
    blob.cell_size = cell_size;
    blob.cells_x = cameras[c].width / cell_size;
    const int cells_y = cameras[c].height / cell_size;
    const Eigen::Vector2i h = (at_hand / cell_size).cast<int>();
    const Eigen::Vector2i a = (at_arm / cell_size).cast<int>();
    for (int y = std::max(0, std::min(h.y(), a.y()) - 3);
         y <= std::min(cells_y - 1, std::max(h.y(), a.y()) + 3); ++y) {
      for (int x = std::max(0, std::min(h.x(), a.x()) - 3);
           x <= std::min(blob.cells_x - 1, std::max(h.x(), a.x()) + 3); ++x) {
        const int i = y * blob.cells_x + x;
        blob.cell_indices.push_back(i);
        if (std::abs(x - h.x()) <= 3 && std::abs(y - h.y()) <= 3)
          blob.moving_cell_indices.push_back(i);
      }
    }
    blob.moving = static_cast<int>(blob.moving_cell_indices.size());
    blob.centroid = 0.5 * (at_hand + at_arm);
    blob.score = static_cast<double>(blob.cell_indices.size());
    total_moving += blob.moving;
    candidates[c].push_back(blob);
  }
  ASSERT_GE(views, 2);
  ASSERT_GT(total_moving, 0);
  const MultiViewParams params;
  const MultiViewChoice at_hand = supportAt(cameras, candidates, hand, params);
  const MultiViewChoice at_arm = supportAt(cameras, candidates, other_arm, params);
  EXPECT_EQ(at_hand.moving, total_moving);
  EXPECT_EQ(at_hand.supporting_views, views);
  EXPECT_EQ(at_arm.supporting_views, views);  // the blob reaches both
  EXPECT_EQ(at_arm.moving, 0);
  // Counting every moving cell of the blob (moving_reach 0, as before session 49), the arm had
  // the user's fingers too.
  MultiViewParams whole_blob = params;
  whole_blob.moving_reach = 0.0;
  EXPECT_EQ(supportAt(cameras, candidates, other_arm, whole_blob).moving, total_moving);
  // A candidate made without its moving cells' places counts all of them, wherever they are.
  for (std::vector<HandCandidate>& view : candidates) {
    for (HandCandidate& candidate : view) candidate.moving_cell_indices.clear();
  }
  EXPECT_EQ(supportAt(cameras, candidates, other_arm, params).moving, total_moving);
  MultiViewParams bad;
  bad.moving_reach = -0.01;
  EXPECT_THROW(validate(bad), InputError);
}

// The kitchen's start (doc/segmentation.md, "Session 49"): the other arm's hand reaches into two
// of the five views at their edges and drifts, while the user's hand, still, is in every view. Two
// views are not a majority: nothing starts until three agree.
TEST(MultiViewConsistency, TwoOfFiveViewsCannotStartTheTrack) {
  const std::vector<Camera>& cameras = dexter5();
  const Eigen::Vector3d hand = studioPose().translation;
  const Eigen::Vector3d other_arm = hand + Eigen::Vector3d(0.35, -0.1, -0.1);
  std::vector<std::vector<HandCandidate>> candidates(cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c) {
    candidates[c].push_back(candidateAt(cameras[c], hand, 200.0, /*moving=*/2));
    if (c == 1 || c == 2) candidates[c].push_back(candidateAt(cameras[c], other_arm, 80.0, 40));
  }
  const MultiViewParams params;
  EXPECT_EQ(viewsNeeded(candidates, params), 3);
  EXPECT_FALSE(chooseConsistentCandidates(cameras, candidates, params).found);
  MultiViewParams any_two = params;
  any_two.min_view_share = 0.0;
  EXPECT_EQ(viewsNeeded(candidates, any_two), 2);
  const MultiViewChoice arm = chooseConsistentCandidates(cameras, candidates, any_two);
  ASSERT_TRUE(arm.found);
  EXPECT_LT((arm.point - other_arm).norm(), 0.005);
  // A third view that sees the arm moving makes it a majority.
  candidates[3].push_back(candidateAt(cameras[3], other_arm, 80.0, 40));
  const MultiViewChoice three = chooseConsistentCandidates(cameras, candidates, params);
  ASSERT_TRUE(three.found);
  EXPECT_EQ(three.supporting_views, 3);
  EXPECT_LT((three.point - other_arm).norm(), 0.005);
  // The views that count are those with candidates: with two cameras (a stereo pair), or three
  // of five without an image, two views agree enough.
  std::vector<std::vector<HandCandidate>> pair(cameras.size());
  pair[1] = candidates[1];
  pair[2] = candidates[2];
  EXPECT_EQ(viewsNeeded(pair, params), 2);
  EXPECT_TRUE(chooseConsistentCandidates(cameras, pair, params).found);
  candidates[4].clear();
  EXPECT_EQ(viewsNeeded(candidates, params), 3);  // 4 views: more than half is 3
  MultiViewParams bad;
  bad.min_view_share = 1.0;
  EXPECT_THROW(validate(bad), InputError);
  bad.min_view_share = -0.1;
  EXPECT_THROW(validate(bad), InputError);
}

TEST(MultiViewConsistency, APointBehindACameraIsNeverChosen) {
  // Two cameras that look at each other's backs from in front: rays that meet behind camera 1.
  const std::vector<Camera>& rig = dexter5();
  std::vector<Camera> cameras{rig[0], rig[1]};
  const Camera& camera = cameras[1];
  const Eigen::Vector3d behind =
      camera.centre() - 0.3 * (camera.world_to_camera.linear().transpose().col(2));
  ASSERT_LT((camera.world_to_camera * behind).z(), 0.0);
  // The centroid in camera 1 whose ray, extended backwards, passes through `behind`: the mirror.
  const Eigen::Vector3d in_front = camera.centre() + (camera.centre() - behind);
  std::vector<std::vector<HandCandidate>> candidates(2);
  Eigen::Vector2d pixel;
  if (!cameras[0].project(behind, &pixel)) GTEST_SKIP() << "behind camera 1 is not seen by 0";
  candidates[0].push_back(candidateAt(cameras[0], behind, 100.0));
  candidates[1].push_back(candidateAt(cameras[1], in_front, 100.0));
  const MultiViewChoice choice = chooseConsistentCandidates(cameras, candidates, MultiViewParams());
  EXPECT_FALSE(choice.found);
  // Nothing is chosen either from a single view, or from views that see different things.
  std::vector<std::vector<HandCandidate>> lonely(rig.size());
  lonely[2].push_back(candidateAt(rig[2], studioPose().translation, 100.0));
  EXPECT_FALSE(chooseConsistentCandidates(rig, lonely, MultiViewParams()).found);
  try {
    chooseConsistentCandidates(rig, candidates, MultiViewParams());
    FAIL() << "mismatched sizes accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("candidates of 2 views"), std::string::npos) << e.what();
  }
  MultiViewParams bad;
  bad.min_views = 1;
  EXPECT_THROW(validate(bad), InputError);
}

// ---- studio rooms -------------------------------------------------------------------------------

TEST(StudioRooms, PropsPhotographsAndLight) {
  for (const std::string& name : builtinRoomNames()) {
    const RoomParams params = builtinRoom(name);
    const StudioRoom room(params, model("sag"), kConfigDir);
    const auto props = room.props(1.0);
    EXPECT_FALSE(props.empty()) << name;
    for (const SurfacePart& part : props) EXPECT_EQ(part.label, kLabelProp) << name;
    EXPECT_FALSE(room.scene().wall_photo.empty()) << name;
    EXPECT_DOUBLE_EQ(room.lightGain(0.0), 1.0);
    EXPECT_NEAR(room.lightGain(0.5 * params.light_period), 1.0 - params.light_change, 1e-12);
  }
  EXPECT_FALSE(builtinRoom("kitchen").hand_free_frames);
  try {
    builtinRoom("garage");
    FAIL() << "unknown room accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("garage"), std::string::npos) << e.what();
  }
  RoomParams missing = builtinRoom("office");
  missing.wall_photo = "no_such_photo.jpg";
  try {
    StudioRoom(missing, model("sag"), kConfigDir);
    FAIL() << "missing photograph accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_photo.jpg"), std::string::npos) << e.what();
  }
}

TEST(StudioRooms, PropsAreRenderedWithTheirLabelAndTheLightDims) {
  const StudioRoom room(builtinRoom("daylight"), model("sag"), kConfigDir);
  const StudioRenderer renderer(dexter5(), room.scene());
  std::vector<std::vector<SurfacePart>> subframes;
  room.addProps(&subframes, 0.0);
  ASSERT_EQ(subframes.size(), 1u);
  const auto bright = renderer.render(subframes, 3, 1.0);
  const auto dim = renderer.render(subframes, 3, 0.6);
  int prop_pixels = 0, views_with_props = 0;
  for (size_t c = 0; c < bright.size(); ++c) {
    const int n = cv::countNonZero(bright[c].labels == kLabelProp);
    prop_pixels += n;
    views_with_props += n > 0;
    EXPECT_LT(cv::mean(dim[c].rgb)[0], 0.8 * cv::mean(bright[c].rgb)[0]) << c;
  }
  EXPECT_GE(views_with_props, 3);
  EXPECT_GT(prop_pixels, 2000);
}

namespace {

// 30 frames of pinch in the office, tracked four ways: skin gate, skin gate + room cues, plate,
// plate + room cues.
std::vector<RoomRunResult> officeWithAndWithoutRoomCues() {
  const Motion motion = loadMotion(resolveMotionPath("pinch", kConfigDir), model("sag"), 1);
  std::vector<RoomRunConfig> configs(4);
  for (int k = 0; k < 4; ++k) {
    configs[k].model = model("sag");
    const bool plate = k >= 2;
    configs[k].pipeline.background_frames = plate ? 10 : 0;
    configs[k].pipeline.segmentation.mode =
        plate ? SegmentationMode::kPlate : SegmentationMode::kSkin;
    configs[k].pipeline.segmentation.room.enabled = k % 2 == 1;
  }
  RoomSequenceOptions options;
  options.frames = 40;
  options.empty_frames = 10;
  const RoomParams office = builtinRoom("office");
  const auto results =
      evaluateRoomSequence(model("sag"), dexter5(), motion, &office, kConfigDir, configs, options);
  for (const RoomRunResult& r : results) {
    std::printf(
        "office, 30 frames with the hand, %d: precision %.3f recall %.3f, error %.1f mm "
        "(%d/%d frames with a pose)\n",
        static_cast<int>(&r - results.data()), r.precision(), r.recall(), r.errors.mean_mm,
        r.frames_posed, r.frames);
    EXPECT_EQ(r.frames, 30);
  }
  return results;
}

}  // namespace

// Issue 11's bar on a short stretch of a room: with the plate and the room cues >= 90 % of the
// foreground is the hand.
TEST(StudioRooms, RoomCuesLiftForegroundPrecisionInTheOffice) {
  const auto results = officeWithAndWithoutRoomCues();
  ASSERT_EQ(results.size(), 4u);
  EXPECT_LT(results[0].precision(), 0.4);  // skin gate alone
  EXPECT_GE(results[3].precision(), 0.9);  // plate + room cues: the bar
  EXPECT_GE(results[3].recall(), 0.85);
  EXPECT_LT(results[3].errors.mean_mm, 25.0);
}

// With the skin gate only (the 10 hand-free frames are tracked too, so the start sees the office's
// still head and portraits first): the multi-view choice of moving candidates keeps the start off
// them until the hand comes into view, and the tracked region keeps the track on the hand.
TEST(StudioRooms, RoomCuesWithTheSkinGateFindTheHandInTheOffice) {
  const auto results = officeWithAndWithoutRoomCues();
  ASSERT_EQ(results.size(), 4u);
  EXPECT_GT(results[1].precision(), 2.0 * results[0].precision());  // skin gate + room cues
  EXPECT_GE(results[1].recall(), 0.85);
  EXPECT_LT(results[1].errors.mean_mm, 25.0);
  // The still head and portraits (still hypotheses, tried with starts of their own) are no hand.
  EXPECT_EQ(results[1].empty_frames, 10);
  EXPECT_EQ(results[1].empty_frames_posed, 0);
}

namespace {

// A hand held still: every frame of the sequence shows the same pose (a real stereo pair replayed
// as a bag is such a sequence: no frame moves).
Motion stillMotion(double seconds) {
  const std::string yaml =
      "name: still\nduration: " + std::to_string(seconds) +
      "\ninterpolation: linear\nshapes:\n"
      "  open: {thumb_cmc_abd: 20, thumb_mcp_flex: 5, index_mcp_abd: 4, ring_mcp_abd: -4,"
      " pinky_mcp_abd: -8}\n"
      "keyframes:\n"
      "  - {time: 0.0, position: [0.0, -0.06, 0.15], orientation: [20, 0, 0], shape: open}\n"
      "  - {time: " +
      std::to_string(seconds) + ", shape: open}\n";
  return parseMotion(yaml, "still", model("sag"), 1);
}

// SAG with the skin gate (no plate) and the room cues.
RoomRunConfig skinGateWithRoomCues() {
  RoomRunConfig config;
  config.model = model("sag");
  config.pipeline.background_frames = 0;
  config.pipeline.segmentation.mode = SegmentationMode::kSkin;
  config.pipeline.segmentation.room.enabled = true;
  return config;
}

// `rendered` held open and still for 20 frames in the office, seen by the first `views` cameras of
// dexter5, no hand-free frames, tracked with each of `configs`.
std::vector<RoomRunResult> stillHandInTheOffice(const HandModel& rendered, int views,
                                                const std::vector<RoomRunConfig>& configs) {
  RoomSequenceOptions options;
  options.frames = 20;
  options.empty_frames = 0;
  const RoomParams office = builtinRoom("office");
  const std::vector<Camera> cameras(dexter5().begin(), dexter5().begin() + views);
  return evaluateRoomSequence(rendered, cameras, stillMotion(1.2), &office, kConfigDir, configs,
                              options);
}

}  // namespace

// A hand held still from the first frame, nothing moving (as a replayed stereo pair of
// photographs), in the office and then the daylight room: the multi-view check finds no moving
// candidates, so each place where still candidates agree is tried with a start of its own
// (MultiViewParams::still_hypotheses); the portraits score below the hand. Without the still
// hypotheses the track never starts.
TEST(StudioRooms, AStillHandIsFoundWithoutMotion) {
  const Motion motion = stillMotion(1.2);
  std::vector<RoomRunConfig> configs{skinGateWithRoomCues(), skinGateWithRoomCues()};
  configs[1].pipeline.multi_view.still_hypotheses = 0;
  for (const int views : {5, 2}) {
    const auto results = stillHandInTheOffice(model("sag"), views, configs);
    for (const RoomRunResult& r : results) {
      std::printf(
          "still hand, office, %d cameras, %s: precision %.3f recall %.3f, error %.1f mm "
          "(%d/%d frames with a pose)\n",
          views, &r == &results[0] ? "still hypotheses" : "none", r.precision(), r.recall(),
          r.errors.mean_mm, r.frames_posed, r.frames);
    }
    ASSERT_EQ(results[0].frames, 20);
    EXPECT_EQ(results[0].frames_posed, 20) << views;
    EXPECT_LT(results[0].errors.mean_mm, 12.0) << views;
    EXPECT_GE(results[0].precision(), 0.85) << views;
    EXPECT_EQ(results[1].frames_posed, 0) << views;
  }
  // The daylight room (a ball at the fingertips, the other hand drifting). Two cameras: the still
  // start took the hand reversed (158 mm) until the sleeve beside it told the wrist's end without
  // a plate. Five: the drifting other hand took the still start over (352.6 mm) while a moving
  // choice needed fewer views than the track.
  const RoomParams daylight = builtinRoom("daylight");
  RoomSequenceOptions options;
  options.frames = 12;
  options.empty_frames = 0;
  configs.resize(1);
  for (const auto& [views, bound] : {std::pair<int, double>{2, 40.0}, {5, 15.0}}) {
    const std::vector<Camera> cameras(dexter5().begin(), dexter5().begin() + views);
    const RoomRunResult r = evaluateRoomSequence(model("sag"), cameras, motion, &daylight,
                                                 kConfigDir, configs, options)[0];
    std::printf(
        "still hand, daylight, %d cameras: precision %.3f recall %.3f, error %.1f mm "
        "(%d/%d frames with a pose)\n",
        views, r.precision(), r.recall(), r.errors.mean_mm, r.frames_posed, r.frames);
    EXPECT_EQ(r.frames_posed, 12) << views;
    EXPECT_LT(r.errors.mean_mm, bound) << views;
  }
}

// The real image pair of issue 11 is a left hand, held still, seen by two cameras, with a face in
// the room. The same as above with the studio's left hand (the mirrored skeleton): tracked with
// --hand left it is found as the right hand is (5 cameras 4.9 mm, 2 cameras 3.0 mm). Tracked as a
// right hand it is 76 mm off with five cameras, but with two its fingertips land within 4 mm:
// two views of a flat open hand do not tell it from its mirror image, so neither would --hand auto
// (doc/studio.md, "Left hands").
TEST(StudioRooms, AStillLeftHandIsFoundWithTwoCameras) {
  const HandModel left = mirrorHandModel(model("sag"));
  std::vector<RoomRunConfig> configs{skinGateWithRoomCues(), skinGateWithRoomCues()};
  configs[0].model = left;  // --hand left
  for (const int views : {5, 2}) {
    const auto results = stillHandInTheOffice(left, views, configs);
    for (const RoomRunResult& r : results) {
      std::printf(
          "still left hand, office, %d cameras, tracked as a %s hand: precision %.3f, error "
          "%.1f mm (%d/%d frames with a pose)\n",
          views, &r == &results[0] ? "left" : "right", r.precision(), r.errors.mean_mm,
          r.frames_posed, r.frames);
    }
    ASSERT_EQ(results[0].frames, 20);
    EXPECT_EQ(results[0].frames_posed, 20) << views;
    EXPECT_LT(results[0].errors.mean_mm, 12.0) << views;
    EXPECT_GE(results[0].precision(), 0.85) << views;
  }
}

// In the daylight room the first set shows no motion yet, so the still hypotheses start a track
// on something lying on the table; that track is provisional (MultiViewParams::
// still_confirm_distance), so the other arm when it drifts, and then the hand when it comes into
// view, take it over (149.7 mm over these 30 frames when a still start was final).
TEST(StudioRooms, AStillStartYieldsToAHandThatComesIntoViewMoving) {
  const Motion motion = loadMotion(resolveMotionPath("pinch", kConfigDir), model("sag"), 1);
  std::vector<RoomRunConfig> configs{skinGateWithRoomCues()};
  RoomSequenceOptions options;
  options.frames = 40;
  options.empty_frames = 10;
  const RoomParams daylight = builtinRoom("daylight");
  const auto results = evaluateRoomSequence(model("sag"), dexter5(), motion, &daylight, kConfigDir,
                                            configs, options);
  const RoomRunResult& r = results[0];
  std::printf(
      "daylight, pinch, 30 frames with the hand: precision %.3f recall %.3f, error %.1f mm "
      "(%d/%d frames with a pose)\n",
      r.precision(), r.recall(), r.errors.mean_mm, r.frames_posed, r.frames);
  ASSERT_EQ(r.frames, 30);
  EXPECT_EQ(r.frames_posed, 30);
  EXPECT_LT(r.errors.mean_mm, 30.0);
  EXPECT_GE(r.recall(), 0.85);
}

namespace {

// The skin gate and the room cues with the calibrated model: its own skin gate, or the generic one.
RoomRunConfig fittedModelWithRoomCues(bool skin_gate_from_model) {
  RoomRunConfig config = skinGateWithRoomCues();
  config.model = fittedDefaultModel();
  config.pipeline.skin_gate_from_model = skin_gate_from_model;
  return config;
}

}  // namespace

// The kitchen (no hand-free frames). The generic gate keeps the wooden table, the coffee and the
// cat on the wall joined with the hand, and until session 22 the track never started. The
// calibrated model's own gate drops most of them (doc/segmentation.md, "Session 22"), and a blob
// far larger than a hand offers its moving part as a candidate of its own (cue 9), with either
// gate. Until session 49 the start took the other arm's drifting hand first with the user's gate
// (the same skin; it moves and two views agree on it), and the user's hand took the track over once
// it moved, at frame 33; a start now needs three of the five views (MultiViewParams::
// min_view_share), and the user's gate waits for the user's hand (below). With the generic gate the
// first 30 frames are 40 mm off (one at 390), then 3-18 mm. The clean studio: 3.5 mm. The default
// model starts on the user's hand 40-90 mm off; until session 23 the other arm took the track at
// frame 4 for 20 frames, because the user's hand, merged with the table into blobs whose centroids
// lie far from it, had the support of one view (supportAt now counts a blob's cells that reach the
// hand).
TEST(StudioRooms, TheTrackStartsInTheKitchenAndStaysOnTheUsersHand) {
  const Motion motion = loadMotion(resolveMotionPath("adbadd", kConfigDir), model("sag"), 1);
  const RoomParams kitchen = builtinRoom("kitchen");
  RoomSequenceOptions options;
  options.frames = 110;
  options.empty_frames = 0;
  RoomRunConfig no_split = fittedModelWithRoomCues(true);
  no_split.pipeline.segmentation.room.split_candidate_share = 0.0;
  RoomRunConfig generic_no_split = fittedModelWithRoomCues(false);
  generic_no_split.pipeline.segmentation.room.split_candidate_share = 0.0;
  const auto results =
      evaluateRoomSequence(model("sag"), dexter5(), motion, &kitchen, kConfigDir,
                           {fittedModelWithRoomCues(true), fittedModelWithRoomCues(false), no_split,
                            generic_no_split, skinGateWithRoomCues()},
                           options);
  ASSERT_EQ(results.size(), 5u);
  std::printf(
      "kitchen, adbadd: the user's gate %d/%d frames with a pose (%.1f mm), generic %d "
      "(%.1f mm); without cue 9: the user's gate %d (%.1f mm), generic %d; the default model %d "
      "(%.1f mm)\n",
      results[0].frames_posed, results[0].frames, results[0].errors.mean_mm,
      results[1].frames_posed, results[1].errors.mean_mm, results[2].frames_posed,
      results[2].errors.mean_mm, results[3].frames_posed, results[4].frames_posed,
      results[4].errors.mean_mm);
  EXPECT_EQ(results[3].frames_posed, 0);  // the generic gate without cue 9 never starts
  // The other arm's hand lies ~460 mm from the user's: from `from` on the track is on the user's.
  auto onTheHand = [](const RoomRunResult& r, size_t from, const char* name) {
    ASSERT_GT(r.errors_mm.size(), from) << name;
    double sum = 0.0;
    for (size_t i = from; i < r.errors_mm.size(); ++i) {
      EXPECT_LT(r.errors_mm[i], 100.0) << name << " " << i;
      sum += r.errors_mm[i];
    }
    EXPECT_LT(sum / (r.errors_mm.size() - from), 15.0) << name;
  };
  // The user's gate: the other arm, which two views see at their edges, cannot start the track
  // (before session 49 it did, and the user's hand took the track over at frame 33); the user's
  // hand starts it once three views agree on it (the 47th set), 50-65 mm off, and the track is
  // within 6 mm of it 27 sets later.
  EXPECT_GE(results[0].frames_posed, 60);
  for (size_t i = 0; i < results[0].errors_mm.size(); ++i) {
    EXPECT_LT(results[0].errors_mm[i], 100.0) << "the user's gate, never on the other arm " << i;
  }
  onTheHand(results[0], 27, "the user's gate");
  EXPECT_GE(results[1].frames_posed, 85);
  onTheHand(results[1], 40, "the generic gate");
  EXPECT_GE(results[4].frames_posed, 100);
  for (size_t i = 0; i < results[4].errors_mm.size(); ++i) {
    EXPECT_LT(results[4].errors_mm[i], 100.0) << "the default model, never on the other arm " << i;
  }
  onTheHand(results[4], 30, "the default model");
}

namespace {

// `sequence` in the kitchen (the hand in view from the first frame) on the default hand or
// `hand`, tracked by `config` (the default model with the generic skin gate and the room cues).
RoomRunResult kitchenFromTheFirstFrame(const std::string& sequence, int frames,
                                       const std::string& hand = "",
                                       const RoomRunConfig& config = skinGateWithRoomCues()) {
  const Motion motion = loadMotion(resolveMotionPath(sequence, kConfigDir), model("sag"), 1);
  const RoomParams kitchen = builtinRoom("kitchen");
  RoomSequenceOptions options;
  options.frames = frames;
  options.empty_frames = 0;
  if (!hand.empty()) options.hand = resolveHandShape(hand, kConfigDir);
  const auto results = evaluateRoomSequence(model("sag"), dexter5(), motion, &kitchen, kConfigDir,
                                            {config}, options);
  EXPECT_EQ(results.size(), 1u);
  return results.at(0);
}

// The mean of errors_mm from `from` on.
double meanErrorFrom(const RoomRunResult& r, size_t from) {
  EXPECT_GT(r.errors_mm.size(), from);
  if (r.errors_mm.size() <= from) return NAN;
  double sum = 0.0;
  for (size_t i = from; i < r.errors_mm.size(); ++i) sum += r.errors_mm[i];
  return sum / static_cast<double>(r.errors_mm.size() - from);
}

}  // namespace

// Adbadd in the kitchen, the default model with the generic gate, the hand in view from the first
// frame: the start is fitted to the candidates' blobs, which hold the wooden table with the hand,
// and took a hand 34-47 mm off; nothing told that track from the hand (its energy 0.65 against
// the hand's 0.76, no loss) until the periodic re-detection 25 sets later. The set after a start
// is segmented in the started hand's region, and the search there
// (PipelineParams::redetect_in_started_region) finds the hand.
TEST(StudioRooms, TheKitchensStartIsSearchedAgainInItsRegion) {
  constexpr int kFrames = 26;
  const RoomRunResult searched = kitchenFromTheFirstFrame("adbadd", kFrames);
  RoomRunConfig once = skinGateWithRoomCues();
  once.pipeline.redetect_in_started_region = false;
  const RoomRunResult started_once = kitchenFromTheFirstFrame("adbadd", kFrames, "", once);
  const double after = meanErrorFrom(searched, 3), before = meanErrorFrom(started_once, 3);
  std::printf(
      "kitchen, adbadd, from the fourth posed frame on: %.1f mm with the search after the start, "
      "%.1f mm without (%d / %d frames posed)\n",
      after, before, searched.frames_posed, started_once.frames_posed);
  EXPECT_EQ(searched.frames_posed, started_once.frames_posed);
  EXPECT_GT(before, 30.0);  // the start this test is about; if it changed, the test needs another
  EXPECT_LT(after, 0.6 * before);
  for (size_t i = 3; i < searched.errors_mm.size(); ++i) {
    EXPECT_LT(searched.errors_mm[i], 30.0) << "posed frame " << i;
  }
}

// Pinch in the kitchen, the default model with the generic gate: the hand is in view from the
// first frame and only its fingers move. Cue 8 (what lay there before the hand) took its age
// quantile from the moving fingers and dropped the still palm, unchanged since the first frame
// like the table, at the start and for the whole track: the start fitted the fingers alone, 64
// deg and 60 mm off, and the track stayed 45-70 mm off (57.0 mm over 110 frames, recall 76 %).
// Cells as old as the first frame are now kept when most of the hand is that old (RoomCueParams::
// first_frame_hand_share; doc/segmentation.md "Session 50"): 4-15 mm over these 60 frames.
TEST(StudioRooms, ThePalmThatHoldsStillFromTheFirstFrameIsKeptInTheKitchen) {
  const RoomRunResult r = kitchenFromTheFirstFrame("pinch", 60);
  std::printf("kitchen, pinch, the default model: %d/%d frames posed, %.1f mm, recall %.3f\n",
              r.frames_posed, r.frames, r.errors.mean_mm, r.recall());
  EXPECT_GE(r.frames_posed, 50);
  for (size_t i = 0; i < r.errors_mm.size(); ++i) EXPECT_LT(r.errors_mm[i], 40.0) << i;
  EXPECT_LT(r.errors.mean_mm, 15.0);
  EXPECT_GE(r.recall(), 0.8);
}

// A hand larger than the model, with other phalanx proportions and brown skin (long_distal_large),
// in the kitchen: with the skin gate the wooden table joins the hand in most views, and the start,
// scored with the paper's normalisation, took a hand grown toward the cameras inside that blob
// (115 mm off, then 20 cm above the table: 362 mm mean over 110 frames, 300-450 mm from the start
// on). The starts are now scored with the model's area charged (PipelineParams::
// skin_gate_start_area_weight); the track stays on the hand (18.7 mm over 110 frames).
TEST(StudioRooms, AHandUnlikeTheModelStartsOnItselfInTheKitchen) {
  // 60 frames: the start comes at the 17th set.
  const RoomRunResult r = kitchenFromTheFirstFrame("adbadd", 60, "long_distal_large");
  std::printf("kitchen, adbadd, long_distal_large: %d/%d frames posed, %.1f mm\n", r.frames_posed,
              r.frames, r.errors.mean_mm);
  EXPECT_GE(r.frames_posed, 40);
  ASSERT_GT(r.errors_mm.size(), 20u);
  double sum = 0.0;
  for (size_t i = 0; i < r.errors_mm.size(); ++i) {
    EXPECT_LT(r.errors_mm[i], 80.0) << i;
    if (i >= 20) sum += r.errors_mm[i];
  }
  EXPECT_LT(sum / (r.errors_mm.size() - 20), 20.0);
}

// In the office the calibrated model's gate cleans the portraits' faces into hand-like blobs, and
// a still start takes one before the hand comes into view (provisional). When the hand comes, it
// takes the track over; what the segmenters learned from the face as the hand's colour is
// forgotten then (forgetTrackedHand), else it kept the hand's start 35-47 mm off for 25 frames.
// (The face's provisional pose in the hand-free frames is the price of the tighter gate: 10 of 10
// here; with the generic gate, 0.)
TEST(StudioRooms, AHandThatReplacesAStillStartIsNotJudgedByTheFacesColours) {
  const Motion motion = loadMotion(resolveMotionPath("adbadd", kConfigDir), model("sag"), 1);
  const RoomParams office = builtinRoom("office");
  RoomSequenceOptions options;
  options.frames = 45;
  options.empty_frames = 10;
  const RoomRunResult r = evaluateRoomSequence(model("sag"), dexter5(), motion, &office, kConfigDir,
                                               {fittedModelWithRoomCues(true)}, options)[0];
  std::printf(
      "office, adbadd, the user's gate: %d/%d frames with a pose, %.1f mm; %d of %d "
      "frames without the hand posed\n",
      r.frames_posed, r.frames, r.errors.mean_mm, r.empty_frames_posed, r.empty_frames);
  EXPECT_EQ(r.frames_posed, r.frames);
  EXPECT_LT(r.errors.mean_mm, 8.0);
  EXPECT_GE(r.recall(), 0.85);
}

TEST(MultiViewConsistency, StillHypothesesAreOnePerPlaceAndNeedTwoViews) {
  const std::vector<Camera>& cameras = dexter5();
  const Eigen::Vector3d hand = studioPose().translation;
  const Eigen::Vector3d head = hand + Eigen::Vector3d(0.0, -0.3, 0.2);
  std::vector<std::vector<HandCandidate>> candidates = stillHeadCandidates(60.0);
  for (size_t c = 0; c < cameras.size(); ++c) {
    candidates[c].insert(candidates[c].begin(), candidateAt(cameras[c], hand, 100.0, /*moving=*/0));
  }
  // A blob in camera 0 only agrees with nothing.
  HandCandidate alone;
  alone.centroid = Eigen::Vector2d(10.0, 20.0);
  alone.score = 900.0;
  alone.cell_indices.assign(900, 0);
  candidates[0].insert(candidates[0].begin(), alone);
  EXPECT_FALSE(chooseConsistentCandidates(cameras, candidates, MultiViewParams()).found);
  const std::vector<MultiViewChoice> still =
      stillHypotheses(cameras, candidates, MultiViewParams());
  ASSERT_EQ(still.size(), 2u);                       // the hand and the head, each once
  EXPECT_LT((still[0].point - hand).norm(), 0.005);  // the higher score
  EXPECT_LT((still[1].point - head).norm(), 0.005);
  EXPECT_EQ(still[0].supporting_views, static_cast<int>(cameras.size()));
  EXPECT_EQ(still[0].chosen[0], 1);  // not the lone blob
  MultiViewParams one;
  one.still_hypotheses = 1;
  EXPECT_EQ(stillHypotheses(cameras, candidates, one).size(), 1u);
  // A hand's size at its depth: the head's blobs grown 20 times (a wall-sized photograph) or
  // shrunk to a 20th (a flower) are no hypothesis.
  const double area = candidateArea(cameras, candidates, still[1]);
  EXPECT_GT(area, MultiViewParams().still_min_area);
  EXPECT_LT(area, MultiViewParams().still_max_area);
  for (const size_t cells : {2000u, 5u}) {
    std::vector<std::vector<HandCandidate>> resized = candidates;
    for (size_t c = 0; c < cameras.size(); ++c) {
      if (still[1].chosen[c] >= 0) resized[c][still[1].chosen[c]].cell_indices.assign(cells, 0);
    }
    const std::vector<MultiViewChoice> only_hand =
        stillHypotheses(cameras, resized, MultiViewParams());
    ASSERT_EQ(only_hand.size(), 1u) << cells;
    EXPECT_LT((only_hand[0].point - hand).norm(), 0.005) << cells;
  }
  MultiViewParams bad;
  bad.still_min_score = 1.5;
  EXPECT_THROW(validate(bad), InputError);
}

TEST(StudioRooms, TheModelOnTheForegroundIsTheShareOfItsCoreThatTheMasksCover) {
  const std::vector<Camera>& cameras = dexter5();
  const PosedHand hand = forwardKinematics(model("sag"), studioPose());
  std::vector<cv::Mat> full, half, none(cameras.size());
  for (const Camera& camera : cameras) {
    full.emplace_back(camera.height, camera.width, CV_8UC1, cv::Scalar(255));
    const cv::Mat core = projectedHandMask(hand, camera, 0, kModelCoreRadius);
    half.push_back(core.clone());
    half.back()(cv::Rect(0, 0, camera.width / 2, camera.height)).setTo(0);
  }
  EXPECT_DOUBLE_EQ(modelOnForeground(hand, cameras, full), 1.0);
  const double share = modelOnForeground(hand, cameras, half);
  EXPECT_GT(share, 0.05);
  EXPECT_LT(share, 0.95);
  EXPECT_DOUBLE_EQ(modelOnForeground(hand, cameras, none), 0.0);  // no camera has a mask
  std::vector<cv::Mat> wrong = full;
  wrong[2] = cv::Mat(10, 10, CV_8UC1, cv::Scalar(255));
  EXPECT_THROW(modelOnForeground(hand, cameras, wrong), InputError);
}

// The still start on hands that are not the model's (config/hand_shapes.yaml: proportions, size,
// skin tone), five cameras, the office: every hand is found the right way round. (Two cameras:
// 6.4-18.2 mm on five of the seven, 51.6 and 60.1 mm on stocky and dark_small;
// doc/segmentation.md.)
TEST(StudioRooms, AStillHandOfEveryShapeIsFoundInTheOffice) {
  const Motion motion = stillMotion(0.5);
  std::vector<RoomRunConfig> configs{skinGateWithRoomCues()};
  RoomSequenceOptions options;
  options.frames = 8;
  options.empty_frames = 0;
  const RoomParams office = builtinRoom("office");
  const std::vector<std::string> shapes = handShapeNames(kConfigDir);
  ASSERT_GE(shapes.size(), 7u);
  for (const std::string& shape : shapes) {
    options.hand = resolveHandShape(shape, kConfigDir);
    const RoomRunResult r = evaluateRoomSequence(model("sag"), dexter5(), motion, &office,
                                                 kConfigDir, configs, options)[0];
    std::printf("still %s, office: precision %.3f recall %.3f, error %.1f mm (%d/%d posed)\n",
                shape.c_str(), r.precision(), r.recall(), r.errors.mean_mm, r.frames_posed,
                r.frames);
    EXPECT_EQ(r.frames_posed, 8) << shape;
    EXPECT_LT(r.errors.mean_mm, 20.0) << shape;
    EXPECT_GE(r.precision(), 0.85) << shape;
  }
}
