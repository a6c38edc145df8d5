#include <gtest/gtest.h>

#include "sag_hand_tracker/apps/metrics.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "sag_hand_tracker/optimization/optimizer.h"
#include "test_support/synthetic_scene.h"

using namespace sag_hand_tracker;
using namespace sag_test;

namespace {

double meanFingertipError(const HandModel& model, const Pose& a, const Pose& b) {
  return sag_hand_tracker::meanFingertipError(fingertips(model, a), fingertips(model, b));
}

// The known pose perturbed by at least 10 degrees on every joint (sign random, kept inside the
// limits), 2 cm and 10 degrees on the root.
Pose perturbed(const HandModel& model, const Pose& truth, std::mt19937& rng) {
  std::bernoulli_distribution coin;
  std::uniform_real_distribution<double> extra(0.0, 2.0);
  const double ten_degrees = 10.0 * M_PI / 180.0;
  Pose start = truth;
  for (int j = 0; j < kNumJointDof; ++j) {
    double delta = (ten_degrees + extra(rng) * M_PI / 180.0) * (coin(rng) ? 1.0 : -1.0);
    if (truth.joints[j] + delta > model.joints[j].max ||
        truth.joints[j] + delta < model.joints[j].min) {
      delta = -delta;
    }
    start.joints[j] += delta;
  }
  const Eigen::Vector3d direction =
      Eigen::Vector3d(coin(rng) ? 1 : -1, coin(rng) ? 1 : -1, 1).normalized();
  start.translation += 0.02 * direction;
  start.rotation =
      rotationFromVector(ten_degrees * Eigen::Vector3d(1, -1, 1).normalized()) * start.rotation;
  return start;
}

}  // namespace

// Recovers a known pose from the image SoG of the model itself in 5 cameras.
TEST(Optimizer, RecoversKnownPoseFromPerturbation) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  const Pose truth = typicalPose(model);
  // The paper's normalisation (model_area_weight 0): the bounds below were measured for where its
  // maximum lies on the model's own silhouette. With the model-area normalisation (the default)
  // the maximum moves: the optimizer still reaches the truth's energy, but trial 0 ends 9.1 mm
  // from the truth (overlapping model Gaussians count their area twice; doc/segmentation.md).
  EnergyParams energy_params;
  energy_params.model_area_weight = 0.0;
  PoseEnergy energy(model, energy_params);
  energy.setFrame(modelObservations(model, truth, cameras, 2.5));
  std::mt19937 rng(3);
  OptimizerParams params;
  params.iterations = 200;
  for (int trial = 0; trial < 3; ++trial) {
    const Pose start = perturbed(model, truth, rng);
    const double before = meanFingertipError(model, start, truth);
    const OptimizationResult result = optimizePose(energy, start, params);
    const double after = meanFingertipError(model, result.pose, truth);
    EXPECT_GT(before, 0.03) << "the perturbation should be large";
    // The optimizer reaches the energy's maximum: at least the energy of the true pose.
    EXPECT_GE(result.energy, energy.evaluate(truth) - 1e-3);
    // The maximum of the energy on a silhouette-like SoG lies a few mm from the generating pose
    // (measured 3-6 mm); recovery means from > 30 mm to below 8 mm.
    EXPECT_LT(after, 0.008) << "trial " << trial << ": fingertip error " << after * 1000 << " mm";
    EXPECT_LT((result.pose.translation - truth.translation).norm(), 0.012);
    EXPECT_GT(result.energy, energy.evaluate(start));
  }
}

TEST(Optimizer, KeepsParametersInsideLimitsAndCountsEvaluations) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  Pose truth = typicalPose(model);
  PoseEnergy energy(model, EnergyParams());
  energy.setFrame(modelObservations(model, truth, cameras));
  Pose start = truth;
  start.joints.setConstant(5.0);  // far outside every limit
  OptimizerParams params;
  const OptimizationResult result = optimizePose(energy, start, params);
  for (int j = 0; j < kNumJointDof; ++j) {
    EXPECT_GE(result.pose.joints[j], model.joints[j].min);
    EXPECT_LE(result.pose.joints[j], model.joints[j].max);
  }
  EXPECT_EQ(result.evaluations, params.iterations + 1);
}

// The model's own images in five cameras, and a start perturbed from the pose that made them.
class AscentFromPerturbedStart : public ::testing::Test {
 protected:
  void SetUp() override {
    energy.setFrame(modelObservations(model, truth, fiveCameraRig()));
    std::mt19937 rng(5);
    start = perturbed(model, truth, rng);
  }
  const HandModel model = loadHandModel(modelPath("sag"));
  const Pose truth = typicalPose(model);
  PoseEnergy energy{model, EnergyParams()};
  Pose start;
};

// An ascent stopped and resumed (PoseAscent, which the counter-turn race uses) goes exactly where
// one run of as many iterations goes, for both step controls.
TEST_F(AscentFromPerturbedStart, ResumedAscentEqualsOneRun) {
  for (const StepControl control : {StepControl::kRprop, StepControl::kFixed}) {
    OptimizerParams params;
    params.step_control = control;
    const OptimizationResult whole = optimizePose(energy, start, params);
    PoseAscent ascent(energy, start, params);
    EXPECT_EQ(ascent.iterations(), 0);
    EXPECT_TRUE(std::isinf(ascent.bestEnergy()));
    ascent.iterate(7);
    EXPECT_EQ(ascent.iterations(), 7);
    const double after_seven = ascent.bestEnergy();
    EXPECT_GT(after_seven, energy.evaluate(start) - 1e-12);
    ascent.iterate(params.iterations - 7);
    EXPECT_GE(ascent.bestEnergy(), after_seven);
    const OptimizationResult resumed = ascent.finish();
    EXPECT_EQ(resumed.energy, whole.energy) << toString(control);
    EXPECT_EQ(resumed.evaluations, whole.evaluations) << toString(control);
    EXPECT_EQ(resumed.pose.toVector(), whole.pose.toVector()) << toString(control);
    EXPECT_GT(whole.energy, energy.evaluate(start)) << toString(control);
  }
}

// More iterations only while the ascent still rises: far from the maximum the extra chunks run
// (up to the bound) and the energy goes on rising; at the maximum none runs; without extra
// iterations it is iterate() exactly.
TEST_F(AscentFromPerturbedStart, ExtraIterationsRunOnlyWhileTheEnergyRises) {
  OptimizerParams params;
  params.iterations = 6;

  PoseAscent plain(energy, start, params);
  plain.iterate(params.iterations);
  PoseAscent rising(energy, start, params);
  const int extra = rising.iterateWhileRising(params.iterations, 10, 3, 1e-4);
  EXPECT_EQ(extra, 9) << "far from the maximum every chunk within the bound runs";
  EXPECT_EQ(rising.iterations(), params.iterations + extra);
  EXPECT_GT(rising.bestEnergy(), plain.bestEnergy() + 1e-4);

  PoseAscent off(energy, start, params);
  EXPECT_EQ(off.iterateWhileRising(params.iterations, 0, 3, 1e-4), 0);
  EXPECT_EQ(off.finish().pose.toVector(), plain.finish().pose.toVector());

  // From the converged pose nothing rises by the gain any more.
  params.iterations = 200;
  const Pose converged = optimizePose(energy, start, params).pose;
  params.iterations = 6;
  PoseAscent at_maximum(energy, converged, params);
  EXPECT_EQ(at_maximum.iterateWhileRising(params.iterations, 10, 3, 1e-3), 0);
  EXPECT_EQ(at_maximum.iterations(), params.iterations);
}

TEST(Optimizer, ParsesStepControl) {
  EXPECT_EQ(parseStepControl("fixed"), StepControl::kFixed);
  EXPECT_EQ(parseStepControl("rprop"), StepControl::kRprop);
  EXPECT_THROW(parseStepControl("newton"), InputError);
}

TEST(Pose, ExtrapolationRepeatsTheLastMotion) {
  Pose a, b;
  a.translation << 0, 0, 0;
  b.translation << 0.01, 0, 0;
  a.rotation = Eigen::Matrix3d::Identity();
  b.rotation = rotationFromVector(Eigen::Vector3d(0, 0, 0.1));
  a.joints.setConstant(0.1);
  b.joints.setConstant(0.2);
  const Pose c = extrapolatePose(a, b);
  EXPECT_NEAR(c.translation.x(), 0.02, 1e-12);
  EXPECT_NEAR(rotationToVector(c.rotation).z(), 0.2, 1e-12);
  EXPECT_NEAR(c.joints[0], 0.3, 1e-12);
  const Pose round_trip = Pose::fromVector(c.toVector());
  EXPECT_TRUE(round_trip.rotation.isApprox(c.rotation, 1e-12));
}

// An adopted re-detection's motion history (HandTracker): extrapolated from it, the adopted pose
// makes the track's turn and wrist shift, with its own joints held still.
TEST(Pose, ThePoseBeforeAMotionExtrapolatesThatMotion) {
  Pose from, to, adopted;
  from.rotation = rotationFromVector(Eigen::Vector3d(0.3, -0.2, 1.0));
  to.rotation = rotationFromVector(Eigen::Vector3d(0.55, -0.1, 1.1));
  from.translation << 0.01, -0.06, 0.16;
  to.translation << 0.015, -0.05, 0.16;
  to.joints.setConstant(0.4);
  adopted.rotation = rotationFromVector(Eigen::Vector3d(0.7, 0.1, 1.2));
  adopted.translation << 0.02, -0.055, 0.17;
  adopted.joints.setConstant(0.8);
  const Pose before = poseBeforeMotion(adopted, from, to);
  const Pose next = extrapolatePose(before, adopted);
  const Eigen::Matrix3d turn = to.rotation * from.rotation.transpose();
  EXPECT_TRUE(next.rotation.isApprox(turn * adopted.rotation, 1e-12));
  EXPECT_TRUE(
      next.translation.isApprox(adopted.translation + to.translation - from.translation, 1e-12));
  EXPECT_TRUE(next.joints.isApprox(adopted.joints, 1e-12));
  // No motion: the pose itself.
  const Pose still = poseBeforeMotion(adopted, to, to);
  EXPECT_TRUE(still.rotation.isApprox(adopted.rotation, 1e-12));
  EXPECT_TRUE(still.translation.isApprox(adopted.translation, 1e-12));
}

// The forearm's direction (issue 9): from straight on from the palm, the search finds a forearm
// turned 20 degrees away, and never leaves the wrist's bound.
TEST(Optimizer, RefinesTheForearmsDirectionWithinTheWristsBound) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const EnergyParams params;
  const Pose truth = typicalPose(model);
  const Eigen::Vector3d bent_in_palm =
      Eigen::AngleAxisd(20.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ()) * -Eigen::Vector3d::UnitX();
  const Eigen::Vector3d bent = truth.rotation * bent_in_palm;
  const Eigen::Vector3d straight = -truth.rotation.col(0);
  PoseEnergy energy(model, params);
  energy.setFrame(
      modelObservations(withForearm(model, params, bent_in_palm), truth, fiveCameraRig()));
  auto angle = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
    return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180.0 / M_PI;
  };

  ForearmSearchParams search;
  search.rounds = 4;
  double found_energy = 0.0;
  const Eigen::Vector3d found =
      refineForearmDirection(energy, truth, straight, search, &found_energy);
  EXPECT_LT(angle(found, bent), 5.0);
  EXPECT_NEAR(found_energy, energy.evaluateWithForearm(truth, found), 1e-12);
  EXPECT_GT(found_energy, energy.evaluateWithForearm(truth, straight));

  search.max_wrist_angle = 10.0 * M_PI / 180.0;
  const Eigen::Vector3d bounded = refineForearmDirection(energy, truth, straight, search);
  EXPECT_LE(angle(bounded, straight), 10.0 + 1e-6);
  EXPECT_GT(angle(bounded, straight), 5.0);  // as far towards the arm as it may
  // A start beyond the bound is pulled back to it; a reversed one to straight on.
  EXPECT_LE(angle(refineForearmDirection(energy, truth, bent, search), straight), 10.0 + 1e-6);
  EXPECT_LE(angle(refineForearmDirection(energy, truth, -straight, search), straight), 10.0 + 1e-6);
}

// The curled hand's refinement (TrackerParams::curled_refine_*) holds the root (its steps 0) and
// the thumb (OptimizerParams::held_joints): from a perturbed start those stay exactly where they
// started while the other joints climb toward the truth.
TEST(Optimizer, HeldJointsAndAZeroRootStepStayWhereTheyStart) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  const Pose truth = typicalPose(model);
  PoseEnergy energy(model, EnergyParams());
  energy.setFrame(modelObservations(model, truth, cameras, 2.5));
  std::mt19937 rng(5);
  Pose start = perturbed(model, truth, rng);
  start.translation = truth.translation;
  start.rotation = truth.rotation;
  OptimizerParams params;
  params.translation_step = 0.0;
  params.rotation_step = 0.0;
  params.held_joints = thumbJoints(model);
  ASSERT_EQ(params.held_joints.size(), 4u);
  const OptimizationResult result = optimizePose(energy, start, params);
  EXPECT_EQ(result.pose.translation, start.translation);
  EXPECT_EQ(result.pose.rotation, start.rotation);
  double moved = 0.0;
  for (int j = 0; j < kNumJointDof; ++j) {
    const bool held = std::count(params.held_joints.begin(), params.held_joints.end(), j) > 0;
    if (held) {
      EXPECT_EQ(result.pose.joints[j], start.joints[j]) << model.joints[j].name;
    } else {
      moved += std::abs(result.pose.joints[j] - start.joints[j]);
    }
  }
  EXPECT_GT(moved, 0.5);  // the free joints did climb
  EXPECT_GT(result.energy, energy.evaluate(start));
}
