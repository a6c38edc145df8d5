// Tests of the hand model fit (hand_fit.h): the shape parameters, the model file writer, the
// routine check, and the fit itself on studio hands of other proportions rendered with the
// calibration routine (config/motions/calibration_routine.yaml).
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <tuple>

#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/energy/hand_projection.h"
#include "sag_hand_tracker/fitting/hand_fit.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/studio/hand_surface.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/studio/renderer.h"
#include "sag_hand_tracker/studio/sequence.h"
#include "sag_hand_tracker/tracking/tracking_pipeline.h"
#include "test_support/synthetic_scene.h"
#include "test_support/temp_files.h"

using namespace sag_hand_tracker;

namespace {

const std::string kSourceDir = SAG_SOURCE_DIR;

const HandModel& handModel() {
  static const HandModel model = loadHandModel(resolveModelPath("sag", kSourceDir + "/config"));
  return model;
}

const std::vector<Camera>& dexter5() {
  static const std::vector<Camera> cameras =
      loadCameraRig(kSourceDir + "/config/rigs/dexter5/rig.yaml").cameras;
  return cameras;
}

const studio::StudioRenderer& sharedRenderer() {
  static const studio::StudioRenderer renderer(dexter5());
  return renderer;
}

HandModel loadFromText(const sag_test::TempDirTest* unused, const std::string& text,
                       const std::string& path) {
  (void)unused;
  std::ofstream(path) << text;
  return loadHandModel(path);
}

void expectSameModel(const HandModel& a, const HandModel& b) {
  ASSERT_EQ(a.bones.size(), b.bones.size());
  ASSERT_EQ(a.gaussians.size(), b.gaussians.size());
  EXPECT_EQ(a.handedness, b.handedness);
  for (size_t i = 0; i < a.bones.size(); ++i) {
    EXPECT_EQ(a.bones[i].name, b.bones[i].name);
    EXPECT_EQ(a.bones[i].parent, b.bones[i].parent);
    EXPECT_LT((a.bones[i].offset - b.bones[i].offset).norm(), 1e-6) << a.bones[i].name;
    EXPECT_LT((a.bones[i].rest_rotation - b.bones[i].rest_rotation).norm(), 1e-5);
    EXPECT_NEAR(a.bones[i].length, b.bones[i].length, 1e-6);
  }
  for (size_t j = 0; j < a.joints.size(); ++j) {
    EXPECT_LT((a.joints[j].axis - b.joints[j].axis).norm(), 1e-12) << a.joints[j].name;
    EXPECT_NEAR(a.joints[j].min, b.joints[j].min, 1e-6);
    EXPECT_NEAR(a.joints[j].max, b.joints[j].max, 1e-6);
  }
  for (size_t g = 0; g < a.gaussians.size(); ++g) {
    EXPECT_LT((a.gaussians[g].mean - b.gaussians[g].mean).norm(), 1e-6);
    EXPECT_LT((a.gaussians[g].cov - b.gaussians[g].cov).norm(), 1e-8);
    EXPECT_LT((a.gaussians[g].hsv - b.gaussians[g].hsv).norm(), 1e-4);
  }
  EXPECT_EQ(a.fingertip_gaussians, b.fingertip_gaussians);
  EXPECT_EQ(a.colours_fitted, b.colours_fitted);
}

class HandModelWriter : public sag_test::TempDirTest {};

TEST_F(HandModelWriter, WrittenModelLoadsBackTheSame) {
  const HandModel& model = handModel();
  expectSameModel(model, loadFromText(this, formatHandModel(model, "a comment"), path("m.yaml")));
}

// calibrate_hand wrote the name bare: "my hand: v2" failed to load back after the whole fit, and
// "hand #2" came back as "hand" (the rest a YAML comment).
TEST_F(HandModelWriter, AnyPrintableNameRoundTrips) {
  HandModel model = handModel();
  for (const std::string name : {"my hand: v2", "hand #2", "*hand", "[left]", "say \"hi\" \\ \\n",
                                 "- x", "'single'", "yes", "~", "  spaced  ", "Håndmodell ✋"}) {
    model.name = name;
    EXPECT_EQ(loadFromText(this, formatHandModel(model), path("named.yaml")).name, name) << name;
  }
}

// A fitted model's colours are the user's: the file says so, and the tracker then keeps them.
TEST_F(HandModelWriter, FittedColoursAreMarkedAndRoundTrip) {
  HandModel model = handModel();
  EXPECT_EQ(formatHandModel(model).find("colours:"), std::string::npos);
  model.colours_fitted = true;
  const std::string text = formatHandModel(model);
  EXPECT_NE(text.find("colours: fitted\n"), std::string::npos);
  expectSameModel(model, loadFromText(this, text, path("fitted.yaml")));
}

TEST_F(HandModelWriter, MirroredAndRotatedGaussiansRoundTrip) {
  // A left hand has reversed joint axes (-z), written as "-z"; a tilted Gaussian gets rpy_deg.
  HandModel model = mirrorHandModel(handModel());
  const Eigen::Matrix3d tilt =
      Eigen::AngleAxisd(0.3, Eigen::Vector3d(0.2, 1.0, 0.4).normalized()).toRotationMatrix();
  model.gaussians[3].cov = tilt * model.gaussians[3].cov * tilt.transpose();
  const std::string text = formatHandModel(model);
  EXPECT_NE(text.find("axis: -z"), std::string::npos);
  expectSameModel(model, loadFromText(this, text, path("left.yaml")));
}

// A routine is tracked without the races, the curled hand's refinement, the extra iterations of a
// rising ascent and the wrist prior (RoutineTracking): calibrate_hand's tracker is the default one
// with those off, and the live ~calibrate switches a running tracker to them and back without
// touching what a reconfigure set. The size adaptation stays as the tracker has it: the fit starts
// at the size it found.
TEST(RoutineTracking, SwitchesATrackerToTheRoutineAndBack) {
  const TrackerParams defaults;
  ASSERT_GT(defaults.counter_turn_race_share, 0.0);
  ASSERT_GT(defaults.redetect_race_iterations, 0);
  ASSERT_GT(defaults.curled_refine_iterations, 0);
  ASSERT_GT(defaults.rising_extra_iterations, 0);
  ASSERT_GT(defaults.energy.wrist_weight, 0.0);
  const TrackerParams offline = calibrationTrackerParams();
  EXPECT_EQ(offline.counter_turn_race_share, 0.0);
  EXPECT_EQ(offline.redetect_race_iterations, 0);
  EXPECT_EQ(offline.curled_refine_iterations, 0);
  EXPECT_EQ(offline.rising_extra_iterations, 0);
  EXPECT_EQ(offline.energy.wrist_weight, calibrationEnergyParams().wrist_weight);
  EXPECT_EQ(offline.energy.wrist_weight, 0.0);
  EXPECT_EQ(offline.optimizer.iterations, defaults.optimizer.iterations);
  EXPECT_EQ(offline.size_step, defaults.size_step);

  TrackerParams live;  // as the live graph runs it, reconfigured
  live.optimizer.iterations = 10;
  live.energy.model_area_weight = 0.7;
  live.curled_refine_iterations = 6;
  live.rising_extra_iterations = 4;
  live.size_step = 0.0;  // switched off by a reconfigure
  const RoutineTracking saved = RoutineTracking::of(live);
  EXPECT_FALSE(saved == RoutineTracking());
  TrackerParams during = live;
  RoutineTracking().applyTo(&during);
  EXPECT_TRUE(RoutineTracking::of(during) == RoutineTracking());
  EXPECT_EQ(during.counter_turn_race_share, 0.0);
  EXPECT_EQ(during.curled_refine_iterations, 0);
  EXPECT_EQ(during.rising_extra_iterations, 0);
  EXPECT_EQ(during.energy.wrist_weight, 0.0);
  EXPECT_EQ(during.optimizer.iterations, 10);
  EXPECT_EQ(during.energy.model_area_weight, 0.7);
  EXPECT_EQ(during.size_step, 0.0);
  during.energy.model_area_weight = 0.5;  // a reconfigure while the routine is collected
  saved.applyTo(&during);
  EXPECT_EQ(during.counter_turn_race_share, live.counter_turn_race_share);
  EXPECT_EQ(during.redetect_race_iterations, live.redetect_race_iterations);
  EXPECT_EQ(during.curled_refine_iterations, 6);
  EXPECT_EQ(during.rising_extra_iterations, 4);
  EXPECT_EQ(during.energy.wrist_weight, live.energy.wrist_weight);
  EXPECT_EQ(during.energy.model_area_weight, 0.5);
}

TEST(HandShape, IdentityKeepsTheModel) {
  const HandModel& model = handModel();
  const HandModel same = applyHandShape(model, HandShapeParameters::identity(model));
  for (size_t b = 0; b < model.bones.size(); ++b) {
    EXPECT_NEAR(same.bones[b].length, model.bones[b].length, 1e-12);
    EXPECT_LT((same.bones[b].offset - model.bones[b].offset).norm(), 1e-12);
  }
  for (size_t g = 0; g < model.gaussians.size(); ++g) {
    EXPECT_LT((same.gaussians[g].cov - model.gaussians[g].cov).norm(), 1e-15);
  }
}

TEST(HandShape, BoneLengthMovesChildrenAndGaussians) {
  const HandModel& model = handModel();
  int bone = -1, child = -1;
  for (size_t b = 0; b < model.bones.size(); ++b) {
    if (model.bones[b].name == "index_middle") bone = static_cast<int>(b);
    if (model.bones[b].name == "index_distal") child = static_cast<int>(b);
  }
  ASSERT_GE(bone, 0);
  ASSERT_GE(child, 0);
  HandShapeParameters shape = HandShapeParameters::identity(model);
  shape.bone_length[bone] = 1.2;
  shape.gaussian_scale[0] = Eigen::Vector3d(1.0, 2.0, 1.0);
  const HandModel shaped = applyHandShape(model, shape);
  EXPECT_NEAR(shaped.bones[bone].length, 1.2 * model.bones[bone].length, 1e-12);
  EXPECT_NEAR(shaped.bones[child].offset.x(), 1.2 * model.bones[child].offset.x(), 1e-12);
  EXPECT_NEAR(shaped.bones[child].length, model.bones[child].length, 1e-12);
  for (size_t g = 0; g < model.gaussians.size(); ++g) {
    if (model.gaussians[g].bone != bone) continue;
    EXPECT_NEAR(shaped.gaussians[g].mean.x(), 1.2 * model.gaussians[g].mean.x(), 1e-12);
    EXPECT_NEAR(shaped.gaussians[g].cov(0, 0), 1.44 * model.gaussians[g].cov(0, 0), 1e-12);
    EXPECT_NEAR(shaped.gaussians[g].cov(1, 1), model.gaussians[g].cov(1, 1), 1e-12);
  }
  // The palm's first Gaussian: twice as wide across the palm (y), unchanged along x.
  EXPECT_NEAR(shaped.gaussians[0].cov(1, 1), 4.0 * model.gaussians[0].cov(1, 1), 1e-12);
  EXPECT_NEAR(shaped.gaussians[0].cov(0, 0), model.gaussians[0].cov(0, 0), 1e-12);

  shape.bone_length[bone] = 0.0;
  EXPECT_NE(sag_test::inputErrorOf([&] { applyHandShape(model, shape); }).find("positive"),
            std::string::npos);
}

// ---- the routine check -------------------------------------------------------------------------

// A frame at `pose` whose cameras each see `gaussians` image Gaussians.
CalibrationFrame frameAt(double stamp, const Pose& pose, int cameras, int gaussians) {
  CalibrationFrame frame;
  frame.stamp = stamp;
  frame.pose = pose;
  for (int c = 0; c < cameras; ++c) {
    CameraObservation observation;
    observation.camera = dexter5()[c];
    for (int i = 0; i < gaussians; ++i) {
      ImageGaussian g;
      g.mean = Eigen::Vector2d(100 + i, 100);
      g.sigma = 2.0;
      observation.sog.gaussians.push_back(g);
    }
    frame.observations.push_back(observation);
  }
  return frame;
}

Pose routinePose(const std::string& what) {
  // Palm down (back up to the cameras above), palm up, or a fist (palm down).
  Pose pose =
      neutralPose(handModel(), Eigen::Vector3d(0, -0.05, 0.15),
                  studio::motionOrientation(Eigen::Vector3d(what == "palm" ? 170 : 0, 0, 0)));
  if (what == "fist") {
    const auto names = handModel().parameterNames();
    for (int j = 0; j < kNumJointDof; ++j) {
      const std::string& name = names[kFirstJointDof + j];
      if (name.find("thumb") != 0 && name.find("_mcp_flex") != std::string::npos)
        pose.joints[j] = 1.45;
      if (name.find("thumb") != 0 && name.find("_pip_flex") != std::string::npos)
        pose.joints[j] = 1.7;
    }
  }
  return pose;
}

std::vector<CalibrationFrame> routineFrames(const std::vector<std::string>& phases, int per_phase,
                                            int cameras) {
  std::vector<CalibrationFrame> frames;
  for (const std::string& phase : phases) {
    for (int i = 0; i < per_phase; ++i) {
      frames.push_back(frameAt(0.04 * frames.size(), routinePose(phase), cameras, 20));
    }
  }
  return frames;
}

std::string joined(const std::vector<std::string>& items) {
  std::string text;
  for (const std::string& item : items) text += item + "; ";
  return text;
}

// The fitted skeleton against a known one: per bone, knuckle and finger, fitted / true - 1.
TEST(SkeletonComparison, ErrorsAgainstAShapedModel) {
  const HandModel model = handModel();
  studio::HandShape shape;
  shape.finger_length[1] = 1.1;  // the index
  const SkeletonErrors same = compareSkeletons(model, model);
  EXPECT_EQ(same.worst_bone, 0.0);
  EXPECT_EQ(same.bonesWithin(0.05), 15);

  const SkeletonErrors errors = compareSkeletons(model, studio::shapeHandModel(model, shape));
  for (int f = 0; f < kNumFingers; ++f) {
    const double expected = f == 1 ? 1.0 / 1.1 - 1.0 : 0.0;
    for (double bone : errors.bone[f]) EXPECT_NEAR(bone, expected, 1e-12) << fingerNames()[f];
    EXPECT_NEAR(errors.finger[f], expected, 1e-12);
    EXPECT_NEAR(errors.knuckle[f], 0.0, 1e-12);
  }
  EXPECT_NEAR(errors.worst_bone, 1.0 - 1.0 / 1.1, 1e-12);
  EXPECT_EQ(errors.bonesWithin(0.05), 12);

  // A longer palm moves every knuckle away from the wrist: the model's knuckles are too close.
  studio::HandShape long_palm;
  long_palm.palm_length = 1.2;
  const SkeletonErrors palm = compareSkeletons(model, studio::shapeHandModel(model, long_palm));
  for (int f = 0; f < kNumFingers; ++f) {
    EXPECT_LT(palm.knuckle[f], -0.01) << fingerNames()[f];
    EXPECT_NEAR(palm.finger[f], 0.0, 1e-12);
  }

  HandModel renamed = model;
  renamed.bones[3].name = "elsewhere";
  EXPECT_NE(sag_test::inputErrorOf([&] { compareSkeletons(renamed, model); }).find("'elsewhere'"),
            std::string::npos);
}

TEST(CalibrationRoutine, AcceptsTheWholeRoutine) {
  const auto frames = routineFrames({"back", "palm", "back", "fist", "back"}, 15, 5);
  const RoutineCheck check = checkCalibrationRoutine(handModel(), frames, 5);
  EXPECT_TRUE(check.ok) << joined(check.missing);
  EXPECT_TRUE(check.complete) << joined(check.missing);
  EXPECT_EQ(check.views, 5);
  EXPECT_EQ(check.fist_frames, 15);
  EXPECT_EQ(check.palm_frames, 15);
}

TEST(CalibrationRoutine, SaysWhatIsMissing) {
  // No palm, no fist: the routine is not complete, but a fit is possible (the first seconds of
  // a sequence; calibrate_hand fits them and warns).
  RoutineCheck check = checkCalibrationRoutine(handModel(), routineFrames({"back"}, 80, 5), 5);
  EXPECT_TRUE(check.ok);
  EXPECT_FALSE(check.complete);
  const std::string missing = joined(check.missing);
  EXPECT_NE(missing.find("the palm was not turned to a camera"), std::string::npos) << missing;
  EXPECT_NE(missing.find("no fist"), std::string::npos) << missing;
  EXPECT_EQ(missing.find("back of the hand"), std::string::npos) << missing;

  // Too short: no fit.
  check = checkCalibrationRoutine(handModel(), routineFrames({"back", "palm", "fist"}, 5, 5), 5);
  EXPECT_FALSE(check.ok);
  EXPECT_FALSE(check.complete);
  EXPECT_NE(joined(check.missing).find("only 15 frames with the hand, the fit needs 40"),
            std::string::npos)
      << joined(check.missing);
  EXPECT_NE(joined(check.missing).find("in view for 0.56 s, the fit needs 2.0 s"),
            std::string::npos);

  // One view; and no hand at all.
  check = checkCalibrationRoutine(handModel(), routineFrames({"back", "palm", "fist"}, 20, 1), 1);
  EXPECT_FALSE(check.ok);
  EXPECT_NE(joined(check.missing).find("the recording has 1 camera; the fit needs at least 2"),
            std::string::npos)
      << joined(check.missing);
  check = checkCalibrationRoutine(handModel(), {}, 5);
  EXPECT_FALSE(check.ok);
  EXPECT_NE(joined(check.missing).find("no frame with the hand"), std::string::npos);
}

// A duration just short of the need is printed with the decimals that show it (1.96 s read "in
// view for 2.0 s, the fit needs 2.0 s"), and a gap longer than max_frame_gap (a clock set forward
// by an hour; calibrate_hand sets the bag reader's 10 s) is no time in view.
TEST(CalibrationRoutine, CountsNoClockJumpAsTimeInView) {
  std::vector<CalibrationFrame> frames = routineFrames({"back"}, 50, 5);
  RoutineCheck check = checkCalibrationRoutine(handModel(), frames, 5);
  EXPECT_NEAR(check.duration, 1.96, 1e-9);
  EXPECT_NE(joined(check.missing).find("the hand was in view for 1.96 s, the fit needs 2.0 s"),
            std::string::npos)
      << joined(check.missing);

  for (std::size_t f = 25; f < frames.size(); ++f) frames[f].stamp += 3600.0;
  check = checkCalibrationRoutine(handModel(), frames, 5);
  EXPECT_NEAR(check.duration, 3601.96, 1e-6);  // without a limit, as before
  RoutineRequirements requirements;
  requirements.max_frame_gap = 10.0;
  check = checkCalibrationRoutine(handModel(), frames, 5, requirements);
  EXPECT_NEAR(check.duration, 1.92, 1e-9);
  EXPECT_FALSE(check.ok);
  EXPECT_NE(joined(check.missing).find("the hand was in view for 1.92 s, the fit needs 2.0 s"),
            std::string::npos)
      << joined(check.missing);
}

// With open_hand_frames the fit takes its frames among the open-hand ones when there are
// min_open_frames of them, and among all frames otherwise (HandFitParams::open_hand_frames).
TEST(HandFitFrames, TheOpenHandFramesWhenThereAreEnough) {
  HandFitParams params;  // nothing to search: only the frame selection and the poses run
  params.open_hand_frames = true;
  params.global_steps.clear();
  params.fit_bones = false;
  params.fit_gaussians = false;
  params.fit_colours = false;
  params.initial_pose_iterations = 1;
  params.pose_optimizer.iterations = 1;
  params.max_frames = 6;
  auto flexion = [](const CalibrationFrame& frame) {
    return meanFingerFlexion(handModel(), frame.pose) * 180.0 / M_PI;
  };

  // 10 open frames among 30 fists: 6 of the open ones, spread over them.
  std::vector<CalibrationFrame> frames = routineFrames({"fist", "back", "fist"}, 10, 2);
  frames.resize(30);
  HandFitResult fit = fitHandModel(handModel(), frames, params);
  EXPECT_TRUE(fit.open_frames_only);
  ASSERT_EQ(fit.frame_indices.size(), 6u);
  for (int index : fit.frame_indices) {
    EXPECT_LE(flexion(frames[index]), kOpenHandFlexionDeg) << index;
    EXPECT_TRUE(index >= 10 && index < 20) << index;
  }
  EXPECT_EQ(fit.frame_indices.front(), 10);  // the middle of the first of 6 parts of 10: 0.83
  EXPECT_EQ(fit.frame_indices.back(), 19);

  // 5 open frames are too few (min_open_frames 8): every frame is a candidate.
  frames = routineFrames({"fist", "back"}, 10, 2);
  frames.resize(15);
  fit = fitHandModel(handModel(), frames, params);
  EXPECT_FALSE(fit.open_frames_only);
  ASSERT_EQ(fit.frame_indices.size(), 6u);
  EXPECT_LT(fit.frame_indices.front(), 10);

  // Without open_hand_frames (a whole routine) every frame is a candidate.
  frames = routineFrames({"fist", "back", "fist"}, 10, 2);
  params.open_hand_frames = false;
  fit = fitHandModel(handModel(), frames, params);
  EXPECT_FALSE(fit.open_frames_only);
  EXPECT_LT(fit.frame_indices.front(), 10);
}

// ---- the fit on studio hands -------------------------------------------------------------------

// Renders `motion` on a hand of `shape` and runs the tracking pipeline with each of `models` on
// the same images; per model the tracked frames (what the cameras saw and the pose) and, per
// tracked frame, the true fingertips.
struct Recording {
  std::vector<CalibrationFrame> frames;
  std::vector<std::array<Eigen::Vector3d, kNumFingers>> true_tips;
  std::vector<Fingertips> tracked_tips;  // the tracker's, of its model at its size
  double model_size = 1.0;               // the tracker's size at the end (TrackerParams::size_step)
};

// `routine`: tracked as calibrate_hand tracks the frames it fits (its tracker parameters).
// `trackers`: per model, the tracker's parameters (empty: the default, or the routine's).
std::vector<Recording> renderAndTrack(const std::string& motion_name,
                                      const studio::HandShape& shape,
                                      const std::vector<HandModel>& models, int frames_limit,
                                      bool routine = false,
                                      const std::vector<TrackerParams>& trackers = {}) {
  const studio::Motion motion = studio::loadMotion(
      studio::resolveMotionPath(motion_name, kSourceDir + "/config"), handModel(), 1);
  studio::SequenceParams params;
  params.shape = shape;
  params.frames = frames_limit;
  const studio::StudioSequence sequence(handModel(), motion, params);
  PipelineParams pipeline_params;
  pipeline_params.background_frames = params.empty_frames;
  if (routine) pipeline_params.tracker = calibrationTrackerParams();  // as calibrate_hand
  std::vector<TrackingPipeline> pipelines;
  for (size_t m = 0; m < models.size(); ++m) {
    PipelineParams model_params = pipeline_params;
    if (m < trackers.size()) model_params.tracker = trackers[m];
    pipelines.emplace_back(models[m], dexter5(), model_params);
  }
  std::vector<Recording> recordings(models.size());
  for (int k = 0; k < sequence.frameCount(); ++k) {
    const auto images = sharedRenderer().render(sequence.surfaces(k), sequence.noiseSeed(k));
    FrameSet set;
    set.stamp_ns = static_cast<std::int64_t>(k) * 40000000LL;
    for (size_t c = 0; c < images.size(); ++c) {
      set.images.push_back({static_cast<int>(c), images[c].rgb});
    }
    for (size_t m = 0; m < models.size(); ++m) {
      std::vector<CameraObservation> observations;
      const ProcessedFrame processed = pipelines[m].process(set, &observations);
      if (processed.background || !processed.result.has_pose) continue;
      CalibrationFrame frame;
      frame.stamp = processed.result.stamp;
      frame.pose = processed.result.pose;
      frame.observations = std::move(observations);
      recordings[m].frames.push_back(std::move(frame));
      recordings[m].true_tips.push_back(sequence.frame(k).fingertips);
      recordings[m].tracked_tips.push_back(processed.result.fingertips);
    }
  }
  for (size_t m = 0; m < models.size(); ++m) {
    recordings[m].model_size = pipelines[m].tracker().sizeFactor();
  }
  return recordings;
}

// Millimetres, over the tracked frames, of the fingertips the tracker reported.
double meanTipError(const Recording& recording) {
  double sum = 0.0;
  int count = 0;
  for (size_t f = 0; f < recording.frames.size(); ++f) {
    for (int i = 0; i < kNumFingers; ++i) {
      sum += (recording.tracked_tips[f][i] - recording.true_tips[f][i]).norm();
      ++count;
    }
  }
  return count > 0 ? 1e3 * sum / count : 1e9;
}

// The silhouette score (the fit's criterion) on the default hand, tracked with the default model:
// the true thickness scores higher than a thinner or a thicker hand, where the overlap score of
// sessions 3-14 prefers the thinner one.
TEST(HandFitScore, TheSilhouetteScorePeaksAtTheRenderedThickness) {
  const Recording pinch = renderAndTrack("pinch", studio::HandShape(), {handModel()}, 14).front();
  ASSERT_GE(pinch.frames.size(), 3u);
  auto shaped = [](double thickness) {
    HandShapeParameters shape = HandShapeParameters::identity(handModel());
    shape.thickness = thickness;
    return applyHandShape(handModel(), shape);
  };
  const HandModel thin = shaped(0.7), thick = shaped(1.4);
  const double sigmas = HandFitParams().silhouette_sigmas;
  for (const CalibrationFrame& frame : pinch.frames) {
    std::vector<cv::Mat> foregrounds;
    for (const CameraObservation& observation : frame.observations) {
      foregrounds.push_back(
          foregroundOfSoG(observation.sog, observation.camera.width, observation.camera.height));
    }
    const double charge = HandFitParams().sleeve_charge;
    const double right =
        silhouetteScore(handModel(), frame.observations, foregrounds, frame.pose, sigmas, charge);
    const double thinner =
        silhouetteScore(thin, frame.observations, foregrounds, frame.pose, sigmas, charge);
    const double thicker =
        silhouetteScore(thick, frame.observations, foregrounds, frame.pose, sigmas, charge);
    std::printf(
        "silhouette score: thickness 0.7 %.3f, 1.0 %.3f, 1.4 %.3f; overlap score %.3f, "
        "%.3f, %.3f\n",
        thinner, right, thicker, shapeScore(thin, EnergyParams(), frame.observations, frame.pose),
        shapeScore(handModel(), EnergyParams(), frame.observations, frame.pose),
        shapeScore(thick, EnergyParams(), frame.observations, frame.pose));
    EXPECT_GT(right, 0.8);
    EXPECT_GT(right, thinner);
    EXPECT_GT(right, thicker);
  }
  // The foregrounds must match the observations.
  EXPECT_THROW(silhouetteScore(handModel(), pinch.frames[0].observations, {}, pinch.frames[0].pose,
                               sigmas, 1.0),
               InputError);
}

// The silhouette score counts within the silhouette's bounding box; it must be the Dice of the
// whole images: the model's silhouette as projectedModelSilhouette draws it. SilhouetteScorer
// (the tracker's finger toggles) gives the same value.
TEST(HandFitScore, TheSilhouetteScoreIsTheDiceOfTheWholeImages) {
  const HandModel model = handModel();
  const std::vector<Camera> cameras = sag_test::fiveCameraRig();
  const Pose truth = sag_test::typicalPose(model);
  const std::vector<CameraObservation> observations =
      sag_test::modelObservations(model, truth, cameras, 4.0);
  const std::vector<cv::Mat> foregrounds = foregroundsOf(observations);
  const double sigmas = HandFitParams().silhouette_sigmas;
  SilhouetteScorer scorer(observations, sigmas, kSleeveChargedAsBackground);
  std::mt19937 random(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int trial = 0; trial < 8; ++trial) {
    Pose pose = truth;
    pose.translation += 0.01 * trial * Eigen::Vector3d(noise(random), noise(random), noise(random));
    for (int j = 0; j < kNumJointDof; ++j) pose.joints[j] += 0.1 * trial * noise(random);
    clampToLimits(model, &pose);
    const PosedHand hand = forwardKinematics(model, pose);
    double whole = 0.0;
    for (size_t c = 0; c < cameras.size(); ++c) {
      const cv::Mat silhouette = projectedModelSilhouette(hand, cameras[c], sigmas, 0);
      whole += 2.0 * cv::countNonZero(foregrounds[c] & silhouette) /
               (cv::countNonZero(foregrounds[c]) + cv::countNonZero(silhouette));
    }
    whole /= static_cast<double>(cameras.size());
    EXPECT_DOUBLE_EQ(
        silhouetteScore(model, observations, foregrounds, pose, sigmas, kSleeveChargedAsBackground),
        whole)
        << "trial " << trial;
    EXPECT_DOUBLE_EQ(scorer.score(model, pose), whole) << "trial " << trial;
  }
}

// Where the sleeve meets the hand (ImageSoG::arm_gaussians) a model pixel counts `sleeve_charge`
// in the model's size: the score is the Dice of the foreground and the model's silhouette with its
// pixels on the sleeve weighted so. A cuff that hides the heel of the hand then costs the true pose
// less; charged in full, the heel drawn on the sleeve costs as if on the background and a hand
// slid toward the fingers scores higher than the truth, the bias that read fitted fingers short.
TEST(HandFitScore, AModelPixelOnTheSleeveCostsTheSleevesCharge) {
  const HandModel model = handModel();
  const std::vector<Camera> cameras = sag_test::fiveCameraRig();
  const Pose truth = sag_test::typicalPose(model);
  std::vector<CameraObservation> observations =
      sag_test::modelObservations(model, truth, cameras, 4.0);
  const Eigen::Vector3d wrist = truth.translation;  // the root is the wrist
  int cameras_with_cuff = 0;
  for (size_t c = 0; c < observations.size(); ++c) {
    // The cuff: the image Gaussians within 25 px of the wrist become sleeve.
    const Eigen::Vector3d local = cameras[c].world_to_camera * wrist;
    const Eigen::Vector2d at = (cameras[c].K * local).hnormalized();
    ImageSoG& sog = observations[c].sog;
    std::vector<ImageGaussian> hand;
    for (const ImageGaussian& g : sog.gaussians) {
      ((g.mean - at).norm() < 25.0 ? sog.arm_gaussians : hand).push_back(g);
    }
    sog.gaussians = hand;
    sog.arm_cells = static_cast<int>(sog.arm_gaussians.size());
    if (!sog.arm_gaussians.empty()) ++cameras_with_cuff;
  }
  ASSERT_GE(cameras_with_cuff, 3);
  const std::vector<cv::Mat> foregrounds = foregroundsOf(observations);
  const double sigmas = HandFitParams().silhouette_sigmas;
  std::mt19937 random(11);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (const double charge : {0.0, 0.5, 1.0}) {
    SilhouetteScorer scorer(observations, sigmas, charge);
    for (int trial = 0; trial < 4; ++trial) {
      Pose pose = truth;
      pose.translation +=
          0.005 * trial * Eigen::Vector3d(noise(random), noise(random), noise(random));
      for (int j = 0; j < kNumJointDof; ++j) pose.joints[j] += 0.05 * trial * noise(random);
      clampToLimits(model, &pose);
      const PosedHand hand = forwardKinematics(model, pose);
      double whole = 0.0;
      for (size_t c = 0; c < cameras.size(); ++c) {
        const cv::Mat occluded = foregrounds[c] == kSilhouetteOccluded;
        EXPECT_EQ(cv::countNonZero(occluded) > 0, !observations[c].sog.arm_gaussians.empty());
        const cv::Mat seen = foregrounds[c] == 255;
        const cv::Mat silhouette = projectedModelSilhouette(hand, cameras[c], sigmas, 0);
        whole += 2.0 * cv::countNonZero(seen & silhouette) /
                 (cv::countNonZero(seen) + cv::countNonZero(silhouette & ~occluded) +
                  charge * cv::countNonZero(silhouette & occluded));
      }
      whole /= static_cast<double>(cameras.size());
      EXPECT_NEAR(silhouetteScore(model, observations, foregrounds, pose, sigmas, charge), whole,
                  1e-12)
          << "charge " << charge << ", trial " << trial;
      EXPECT_NEAR(scorer.score(model, pose), whole, 1e-12)
          << "charge " << charge << ", trial " << trial;
    }
  }
  // The true pose under the cuff, and the hand slid 7 mm toward the fingers (where the visible
  // palm begins).
  const Eigen::Vector3d toward_fingers =
      (fingertips(model, truth)[2] - truth.translation).normalized();
  Pose slid = truth;
  slid.translation += 0.007 * toward_fingers;
  SilhouetteScorer uncharged(observations, sigmas, 0.0);
  SilhouetteScorer charged(observations, sigmas, kSleeveChargedAsBackground);
  std::printf("true pose %.4f, slid %.4f; charged in full %.4f, %.4f\n",
              uncharged.score(model, truth), uncharged.score(model, slid),
              charged.score(model, truth), charged.score(model, slid));
  EXPECT_GT(uncharged.score(model, truth), uncharged.score(model, slid));
  EXPECT_LT(charged.score(model, truth), charged.score(model, slid));
  EXPECT_GT(uncharged.score(model, truth), charged.score(model, truth) + 0.1);
}

TEST(HandFitScore, TheForegroundOfASoGIsItsLeaves) {
  ImageSoG sog;
  sog.width = 64;
  sog.height = 48;
  const double sigma_per_side = QuadtreeParams().sigma_per_leaf_size;
  for (const auto& [x, y, side] : {std::tuple<double, double, double>{10, 10, 4},
                                   {30, 20, 16},
                                   {62, 46, 8}}) {  // the last one clipped
    ImageGaussian g;
    g.mean = Eigen::Vector2d(x, y);
    g.sigma = sigma_per_side * side;
    sog.gaussians.push_back(g);
  }
  const cv::Mat mask = foregroundOfSoG(sog, sog.width, sog.height);
  EXPECT_EQ(cv::countNonZero(mask), 4 * 4 + 16 * 16 + 6 * 6);
  EXPECT_EQ(mask.at<unsigned char>(20, 30), 255);
  EXPECT_EQ(mask.at<unsigned char>(0, 0), 0);
}

struct ShapeCase {
  const char* name;
  studio::HandShape shape;
};

studio::HandShape makeShape(double palm, double fingers, double thickness) {
  studio::HandShape shape;
  shape.palm_width = palm;
  shape.finger_length.fill(fingers);
  shape.thickness = thickness;
  return shape;
}

// Issue 10's hands: +-15 % bone lengths and palm width, +-20 % thickness.
const std::vector<ShapeCase>& shapeCases() {
  static const std::vector<ShapeCase> cases{{"long_thin", makeShape(0.85, 1.15, 0.8)},
                                            {"short_wide_thick", makeShape(1.15, 0.85, 1.2)}};
  return cases;
}

// The routine on each hand, tracked with the default model, and the fit (computed once).
const HandFitResult& fitFor(int shape_case) {
  static std::map<int, HandFitResult> fits;
  auto it = fits.find(shape_case);
  if (it != fits.end()) return it->second;
  const studio::HandShape& shape = shapeCases()[shape_case].shape;
  const Recording routine =
      renderAndTrack("calibration_routine", shape, {handModel()}, 0, true).front();
  const RoutineCheck check = checkCalibrationRoutine(handModel(), routine.frames, 5);
  EXPECT_TRUE(check.ok) << joined(check.missing);
  HandFitParams params;
  params.max_frames = 10;
  params.rounds = 1;
  return fits.emplace(shape_case, fitHandModel(handModel(), routine.frames, params)).first->second;
}

class FitOnStudioHands : public ::testing::TestWithParam<int> {};

// Tracking a sequence of that hand (the first 1.6 s of pinch) with the fitted model beats the
// default model.
TEST_P(FitOnStudioHands, TrackingWithTheFittedModelBeatsTheDefault) {
  const ShapeCase& shape_case = shapeCases()[GetParam()];
  const HandFitResult& fit = fitFor(GetParam());
  EXPECT_GT(fit.score_after, fit.score_before);
  const std::vector<Recording> pinch =
      renderAndTrack("pinch", shape_case.shape, {handModel(), fit.model}, 50);
  const double default_error = meanTipError(pinch[0]);
  const double fitted_error = meanTipError(pinch[1]);
  RecordProperty("default_mm", std::to_string(default_error));
  RecordProperty("fitted_mm", std::to_string(fitted_error));
  EXPECT_LT(fitted_error, default_error) << shape_case.name;
}

// The fitted thickness follows the rendered hand's (0.8 and 1.2). The overlap score of sessions
// 3-14 thinned every hand to 0.6-0.83, the default one to 0.66 (doc/calibration.md).
TEST_P(FitOnStudioHands, TheFittedThicknessIsTheHands) {
  const ShapeCase& shape_case = shapeCases()[GetParam()];
  const HandFitResult& fit = fitFor(GetParam());
  std::printf("%s: thickness %.3f (rendered %.2f), size %.3f, palm width %.3f, fingers %.3f\n",
              shape_case.name, fit.shape.thickness, shape_case.shape.thickness, fit.shape.scale,
              fit.shape.palm_width, fit.shape.finger_length);
  EXPECT_NEAR(fit.shape.thickness, shape_case.shape.thickness, 0.1) << shape_case.name;
}

// The bar of issue 10: every fitted finger bone within 5 % of the rendered hand's. Met on these
// two hands since session 15's silhouette score (before it, with the overlap score, single fingers
// were off by up to 8 % and the thumb of short_wide_thick by 14.5 %, and this test was disabled).
// Not met on every studio hand: calibrate_hand gives the benchmark's stocky hand fingers 13.6 %
// short, and a finger's phalanges share one factor, so long_distal's split is out of reach
// (doc/calibration.md, "Session 15").
TEST_P(FitOnStudioHands, BoneLengthsWithinFivePercent) {
  const ShapeCase& shape_case = shapeCases()[GetParam()];
  const HandFitResult& fit = fitFor(GetParam());
  const HandModel truth = studio::shapeHandModel(handModel(), shape_case.shape);
  const auto chains = studio::fingerChains(handModel());
  for (int f = 0; f < kNumFingers; ++f) {
    for (int b : chains[f]) {
      const double error = fit.model.bones[b].length / truth.bones[b].length - 1.0;
      EXPECT_LT(std::abs(error), kFitBoneTolerance)
          << shape_case.name << " " << truth.bones[b].name << ": fitted "
          << 1e3 * fit.model.bones[b].length << " mm, true " << 1e3 * truth.bones[b].length
          << " mm (default " << 1e3 * handModel().bones[b].length << " mm)";
    }
  }
}

// Fitted from the first 3 s of another sequence (not the routine: no palm turned up; `random`'s
// fists and turns), the model still tracks pinch better than the default one: the fit takes the
// open-hand frames (HandFitParams::open_hand_frames). From all 65 frames, the benchmark's hands
// tracked worse than with the default model (doc/calibration.md, "Session 16").
TEST_P(FitOnStudioHands, FittedFromTheFirstThreeSecondsOfAnotherSequence) {
  const ShapeCase& shape_case = shapeCases()[GetParam()];
  const Recording start =
      renderAndTrack("random", shape_case.shape, {handModel()}, 75, true).front();
  const RoutineCheck check = checkCalibrationRoutine(handModel(), start.frames, 5);
  EXPECT_TRUE(check.ok) << joined(check.missing);
  EXPECT_FALSE(check.complete);
  HandFitParams params;
  params.max_frames = 10;
  params.rounds = 1;
  params.open_hand_frames = !check.complete;  // as calibrate_hand
  const HandFitResult fit = fitHandModel(handModel(), start.frames, params);
  EXPECT_TRUE(fit.open_frames_only);
  const std::vector<Recording> pinch =
      renderAndTrack("pinch", shape_case.shape, {handModel(), fit.model}, 50);
  const double default_error = meanTipError(pinch[0]);
  const double fitted_error = meanTipError(pinch[1]);
  std::printf("%s, fitted from random's first 3 s: pinch %.1f mm (default model %.1f mm)\n",
              shape_case.name, fitted_error, default_error);
  EXPECT_LT(fitted_error, default_error) << shape_case.name;
}

// The tracker's size adaptation (TrackerParams::size_step) on rendered hands 10 % larger and
// smaller than the model (tapered capsules, not the model's ellipsoids): the model ends within two
// steps of the hand's size, on the model's own hand within one of 1, and the larger and smaller
// hands' fingertips come closer than without it. An open hand (adbadd), 3.2 s.
TEST(TrackerSize, TheModelTakesTheSizeOfARenderedHand) {
  const TrackerParams defaults;
  ASSERT_GT(defaults.size_step, 0.0);
  for (const double size : {1.1, 1.0, 0.9}) {
    studio::HandShape shape;
    shape.scale = size;
    TrackerParams fixed_size;
    fixed_size.size_step = 0.0;
    const std::vector<Recording> runs = renderAndTrack("adbadd", shape, {handModel(), handModel()},
                                                       80, false, {defaults, fixed_size});
    const double adapted = meanTipError(runs[0]), kept = meanTipError(runs[1]);
    std::printf("hand %.2f: model %.3f, %.1f mm; kept at 1: %.1f mm\n", size, runs[0].model_size,
                adapted, kept);
    EXPECT_EQ(runs[1].model_size, 1.0);
    EXPECT_NEAR(runs[0].model_size, size, (size == 1.0 ? 1.01 : 2.01) * defaults.size_step * size);
    if (size != 1.0) EXPECT_LT(adapted, kept);
  }
}

// The size trial scores each size at the tracked pose refined for it
// (TrackerParams::size_refine_iterations): at the tracked pose itself, fitted with the current
// size, a finger tracked a little curled reads as a longer hand. On the model's own hand in
// `pinch` the size stays within one step of 1 with the refinement (without it: 1.02).
TEST(TrackerSize, EachSizeIsScoredAtAPoseFittedToIt) {
  const TrackerParams defaults;
  ASSERT_GT(defaults.size_refine_iterations, 0);
  TrackerParams at_tracked_pose = defaults;
  at_tracked_pose.size_refine_iterations = 0;
  const std::vector<Recording> runs =
      renderAndTrack("pinch", studio::HandShape(), {handModel(), handModel()}, 150, false,
                     {defaults, at_tracked_pose});
  std::printf("the model's own hand, pinch: size %.3f refined, %.3f at the tracked pose\n",
              runs[0].model_size, runs[1].model_size);
  EXPECT_NEAR(runs[0].model_size, 1.0, 0.5 * defaults.size_step);
  EXPECT_LT(std::abs(runs[0].model_size - 1.0), std::abs(runs[1].model_size - 1.0));
}

INSTANTIATE_TEST_SUITE_P(Shapes, FitOnStudioHands, ::testing::Values(0, 1),
                         [](const ::testing::TestParamInfo<int>& info) {
                           return std::string(shapeCases()[info.param].name);
                         });

}  // namespace
