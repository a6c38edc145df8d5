#include <gtest/gtest.h>

#include <array>

#include <cmath>
#include <functional>
#include <optional>
#include <random>

#include "sag_hand_tracker/energy/energy.h"
#include "sag_hand_tracker/tracking/tracker.h"
#include "test_support/synthetic_scene.h"

using namespace sag_hand_tracker;
using namespace sag_test;

namespace {

// A random pose near the typical one: every parameter moved, joints across their range.
Pose randomPose(const HandModel& model, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0), symmetric(-1.0, 1.0);
  Pose pose = typicalPose(model);
  pose.translation += 0.02 * Eigen::Vector3d(symmetric(rng), symmetric(rng), symmetric(rng));
  pose.rotation =
      rotationFromVector(0.3 * Eigen::Vector3d(symmetric(rng), symmetric(rng), symmetric(rng))) *
      pose.rotation;
  for (int j = 0; j < kNumJointDof; ++j) {
    // Slightly beyond the limits too, so the limit penalty's gradient is exercised.
    const double span = model.joints[j].max - model.joints[j].min;
    pose.joints[j] = model.joints[j].min - 0.1 * span + 1.2 * span * unit(rng);
  }
  return pose;
}

// Central difference along parameter i; the orientation in the tangent space (see pose.h).
double centralDifference(const PoseEnergy& energy, const Pose& pose, int i, double h) {
  PoseVector step = PoseVector::Zero();
  step[i] = h;
  const double plus = energy.evaluate(pose.stepped(step));
  step[i] = -h;
  const double minus = energy.evaluate(pose.stepped(step));
  return (plus - minus) / (2.0 * h);
}

// The analytic gradient at `pose` against central differences in every parameter (relative error,
// against the parameter's own size or 1e-3 of the largest component); returns how many it checked.
int expectGradientMatches(const PoseEnergy& energy, const HandModel& model, const Pose& pose,
                          const std::string& label) {
  PoseVector gradient;
  energy.evaluate(pose, &gradient);
  const double scale = gradient.cwiseAbs().maxCoeff();
  EXPECT_GT(scale, 0.0) << label;
  if (!(scale > 0.0)) return 0;
  for (int i = 0; i < kNumDof; ++i) {
    const double h = i < 3 ? 1e-6 : 1e-5;  // metres / radians
    double numeric = centralDifference(energy, pose, i, h);
    // Eq. 8's cap is a kink; where one lies within the step, the differences over h and h/10
    // disagree, and the smaller step is the one that sees the gradient.
    const double finer = centralDifference(energy, pose, i, 0.1 * h);
    if (std::fabs(finer - numeric) > 1e-4 * std::max(std::fabs(finer), 1e-3 * scale)) {
      numeric = finer;
    }
    EXPECT_NEAR(gradient[i], numeric, 1e-4 * std::max(std::fabs(numeric), 1e-3 * scale))
        << label << " parameter " << model.parameterNames()[i];
  }
  return kNumDof;
}

// The analytic gradient against central differences at 4 random poses, with `params` (no cut-off
// and double pair kernels added), on the images of the typical pose, edited by `edit` when given.
void checkGradientWith(
    const std::string& model_name, EnergyParams params,
    const std::function<void(const Pose&, std::vector<CameraObservation>&)>& edit = {}) {
  const HandModel model = loadHandModel(modelPath(model_name));
  const std::vector<Camera> cameras = fiveCameraRig();
  std::mt19937 rng(42);
  params.max_mahalanobis_sq = 1e9;  // no cut-off: the energy is then smooth everywhere
  params.float_pairs = false;       // float rounding would swamp the differences
  PoseEnergy energy(model, params);
  // Image from one pose, gradient at others: many pairs unsaturated, many partially overlapping.
  std::vector<CameraObservation> observations =
      modelObservations(model, typicalPose(model), cameras, 6.0);
  if (edit) edit(typicalPose(model), observations);
  energy.setFrame(observations);
  int checked = 0;
  for (int trial = 0; trial < 4; ++trial) {
    checked += expectGradientMatches(energy, model, randomPose(model, rng),
                                     model_name + " trial " + std::to_string(trial));
  }
  EXPECT_EQ(checked, 4 * kNumDof);
}

void checkGradient(const std::string& model_name,
                   double coupling = EnergyParams().dip_pip_coupling_weight,
                   double model_area_weight = EnergyParams().model_area_weight,
                   double joint_range_weight = EnergyParams().joint_range_weight,
                   double saturation_softness = EnergyParams().saturation_softness,
                   double occlusion_depth_scale = EnergyParams().occlusion_depth_scale,
                   double finger_order_weight = EnergyParams().finger_order_weight,
                   double finger_collision_weight = EnergyParams().finger_collision_weight,
                   double finger_collision_threshold = EnergyParams().finger_collision_threshold) {
  EnergyParams params;
  params.dip_pip_coupling_weight = coupling;
  params.model_area_weight = model_area_weight;
  params.joint_range_weight = joint_range_weight;
  params.saturation_softness = saturation_softness;
  params.occlusion_depth_scale = occlusion_depth_scale;
  params.finger_order_weight = finger_order_weight;
  params.finger_collision_weight = finger_collision_weight;
  params.finger_collision_threshold = finger_collision_threshold;
  checkGradientWith(model_name, params);
}

// E_sim less every prior of `params` at its weight: what EnergyTerms::total must be.
double weightedTotal(const EnergyParams& params, const EnergyTerms& terms) {
  return terms.similarity - params.limit_weight * terms.limit_penalty -
         params.dip_pip_coupling_weight * terms.coupling_penalty -
         params.finger_order_weight * terms.order_penalty -
         params.fan_turn_weight * terms.fan_turn_penalty -
         params.finger_collision_weight * terms.collision_penalty -
         terms.range_penalty -  // weighted per joint (EnergyParams::thumb_range_weight)
         params.wrist_weight * terms.wrist_penalty;
}

// Forearm evidence (ImageSoG::arm_cells) in every camera at the image of `point`, as the
// segmentation reports the sleeve's end.
void addArmEvidenceAt(const Eigen::Vector3d& point, std::vector<CameraObservation>& observations) {
  for (CameraObservation& observation : observations) {
    Eigen::Vector2d pixel;
    ASSERT_TRUE(observation.camera.project(point, &pixel));
    observation.sog.arm_cells = 30;
    observation.sog.arm_centroid = pixel;
  }
}

// A point `distance` up the forearm from the wrist of `pose` (the root's -x axis).
Eigen::Vector3d upTheArm(const Pose& pose, double distance) {
  return pose.translation - distance * pose.rotation.col(0);
}

// The index of the model's joint `name` among the joint parameters (a test failure if none).
int jointNamed(const HandModel& model, const std::string& name) {
  const int j = model.jointIndex(name);
  if (j >= 0) return j;
  ADD_FAILURE() << "no joint " << name;
  return 0;
}

// The energy at `truth` is above its value with the hand moved 2 cm and with the pinky curled.
void expectTruthBeatsNearbyPoses(const PoseEnergy& energy, const Pose& truth, double at_truth) {
  Pose moved = truth;
  moved.translation.x() += 0.02;
  EXPECT_GT(at_truth, energy.evaluate(moved));
  moved = truth;
  moved.joints[kNumJointDof - 3] += 0.5;  // pinky MCP flexion
  EXPECT_GT(at_truth, energy.evaluate(moved));
}

}  // namespace

// The analytic / forward-mode gradient equals central differences for all 26 parameters,
// relative error below 1e-4.
TEST(EnergyGradient, SagMatchesCentralDifferences) { checkGradient("sag"); }
TEST(EnergyGradient, SogMatchesCentralDifferences) { checkGradient("sog"); }
// The same with a strong PIP-DIP coupling prior, so that its gradient matters.
TEST(EnergyGradient, SagWithStrongPipDipCouplingMatchesCentralDifferences) {
  checkGradient("sag", 1.0);
}
// The same with the model's area in the normalisation (model_area_weight 1, opt-in).
TEST(EnergyGradient, SagWithModelAreaNormalisationMatchesCentralDifferences) {
  checkGradient("sag", EnergyParams().dip_pip_coupling_weight, 1.0);
}
TEST(EnergyGradient, SogWithModelAreaNormalisationMatchesCentralDifferences) {
  checkGradient("sog", EnergyParams().dip_pip_coupling_weight, 1.0);
}

// The same with a strong joint-range prior.
TEST(EnergyGradient, SagWithStrongJointRangePriorMatchesCentralDifferences) {
  checkGradient("sag", EnergyParams().dip_pip_coupling_weight, EnergyParams().model_area_weight,
                1.0);
  EnergyParams thumb;
  thumb.thumb_range_weight = 2.0;
  checkGradientWith("sag", thumb);
}

// The same with a strong finger order prior (the random poses cross neighbouring fingers).
TEST(EnergyGradient, SagWithStrongFingerOrderPriorMatchesCentralDifferences) {
  const EnergyParams defaults;
  checkGradient("sag", defaults.dip_pip_coupling_weight, defaults.model_area_weight,
                defaults.joint_range_weight, defaults.saturation_softness,
                defaults.occlusion_depth_scale, 5.0);
}

// The same with a strong fan-turn prior: every pose charged (margin 0), and only the random poses
// whose long fingers turn together by more than a small margin.
TEST(EnergyGradient, SagWithStrongFanTurnPriorMatchesCentralDifferences) {
  for (const double margin : {0.0, 0.05}) {
    EnergyParams params;
    params.fan_turn_weight = 5.0;
    params.fan_turn_margin = margin;
    checkGradientWith("sag", params);
  }
}

// The same with a strong finger collision prior: every pair of neighbouring fingers' Gaussians
// (threshold 0), and only the close ones (the default threshold).
TEST(EnergyGradient, SagWithStrongFingerCollisionPriorMatchesCentralDifferences) {
  const EnergyParams defaults;
  for (const double threshold : {0.0, defaults.finger_collision_threshold}) {
    checkGradient("sag", defaults.dip_pip_coupling_weight, defaults.model_area_weight,
                  defaults.joint_range_weight, defaults.saturation_softness,
                  defaults.occlusion_depth_scale, defaults.finger_order_weight, 5.0, threshold);
  }
}

// The same with a strong wrist prior: evidence 1 cm up the arm of the typical pose, the random
// poses' wrists up to a few cm from its rays, charged beyond a small tolerance.
TEST(EnergyGradient, SagWithStrongWristPriorMatchesCentralDifferences) {
  EnergyParams params;
  params.wrist_weight = 5.0;
  params.wrist_tolerance = 0.003;
  params.wrist_scale = 0.01;
  checkGradientWith("sag", params, [](const Pose& truth, std::vector<CameraObservation>& obs) {
    addArmEvidenceAt(upTheArm(truth, 0.01), obs);
  });
}

// The same with the soft saturation of eq. 8 (EnergyParams::saturation_softness 1 and 0.5).
TEST(EnergyGradient, SagWithSoftSaturationMatchesCentralDifferences) {
  checkGradient("sag", EnergyParams().dip_pip_coupling_weight, EnergyParams().model_area_weight,
                EnergyParams().joint_range_weight, 1.0);
  checkGradient("sag", EnergyParams().dip_pip_coupling_weight, EnergyParams().model_area_weight,
                EnergyParams().joint_range_weight, 0.5);
}

// The same with occlusion (EnergyParams::occlusion_depth_scale): the visibility's derivatives
// through every pair of model Gaussians and their depths, with and without the model's area.
TEST(EnergyGradient, SagWithOcclusionMatchesCentralDifferences) {
  const EnergyParams defaults;
  checkGradient("sag", defaults.dip_pip_coupling_weight, 0.0, defaults.joint_range_weight,
                defaults.saturation_softness, 0.005);
  checkGradient("sag", defaults.dip_pip_coupling_weight, 1.0, defaults.joint_range_weight,
                defaults.saturation_softness, 0.005);
  checkGradient("sag", defaults.dip_pip_coupling_weight, 1.0, defaults.joint_range_weight, 0.0,
                0.02);
}
TEST(EnergyGradient, SogWithOcclusionMatchesCentralDifferences) {
  const EnergyParams defaults;
  checkGradient("sog", defaults.dip_pip_coupling_weight, 1.0, defaults.joint_range_weight,
                defaults.saturation_softness, 0.005);
}

// The soft saturation E_qq (1 - exp(-S / E_qq)) (EnergyParams::saturation_softness 1) never exceeds
// the paper's min(S, E_qq), so it is below it wherever the model covers the image; the true pose
// still scores above perturbed ones.
TEST(Energy, SoftSaturationIsBelowTheCapAndPeaksAtTheTruth) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const Pose truth = typicalPose(model);
  const std::vector<CameraObservation> observations =
      modelObservations(model, truth, fiveCameraRig());
  EnergyParams hard_params, soft_params;
  hard_params.saturation_softness = 0.0;
  soft_params.saturation_softness = 1.0;
  PoseEnergy hard(model, hard_params), soft(model, soft_params);
  hard.setFrame(observations);
  soft.setFrame(observations);
  EnergyTerms hard_terms, soft_terms;
  const double at_truth = soft.evaluate(truth, nullptr, &soft_terms);
  hard.evaluate(truth, nullptr, &hard_terms);
  EXPECT_GT(soft_terms.similarity, 0.3);
  EXPECT_LT(soft_terms.similarity, hard_terms.similarity - 0.01);
  expectTruthBeatsNearbyPoses(soft, truth, at_truth);
  // Far from every foreground Gaussian both are 0.
  Pose moved = truth;
  moved.translation.z() += 5.0;
  EXPECT_NEAR(soft.evaluate(moved), hard.evaluate(moved), 1e-9);
  // Half soft is half way.
  EnergyParams half_params;
  half_params.saturation_softness = 0.5;
  PoseEnergy half(model, half_params);
  half.setFrame(observations);
  EnergyTerms half_terms;
  half.evaluate(truth, nullptr, &half_terms);
  EXPECT_NEAR(half_terms.similarity, 0.5 * (hard_terms.similarity + soft_terms.similarity), 1e-9);
  // Outside [0, 1]: refused.
  for (const double bad : {-0.1, 1.5, std::nan("")}) {
    EnergyParams bad_params;
    bad_params.saturation_softness = bad;
    EXPECT_THROW(PoseEnergy(model, bad_params), InputError) << bad;
  }
}

namespace {

// typicalPose with every joint in the middle of its limits.
Pose midRangePose(const HandModel& model) {
  Pose pose = typicalPose(model);
  for (int j = 0; j < kNumJointDof; ++j) {
    pose.joints[j] = 0.5 * (model.joints[j].min + model.joints[j].max);
  }
  return pose;
}

}  // namespace

// The joint-range prior: zero with every joint in the middle of its limits, its weight per joint
// at a limit (the thumb's own weight for the thumb's joints), and it lowers the energy by that.
TEST(Energy, JointRangePriorIsZeroMidRangeAndItsWeightPerJointAtALimit) {
  const HandModel model = loadHandModel(modelPath("sag"));
  EnergyParams params;
  params.joint_range_weight = 0.25;
  params.thumb_range_weight = 0.5;
  PoseEnergy energy(model, params);
  energy.setFrame(modelObservations(model, typicalPose(model), fiveCameraRig(), 6.0));
  Pose pose = midRangePose(model);
  EnergyTerms mid;
  energy.evaluate(pose, nullptr, &mid);
  EXPECT_NEAR(mid.range_penalty, 0.0, 1e-12);
  const int thumb_ip = model.jointIndex("thumb_ip_flex");
  const int index_pip = model.jointIndex("index_pip_flex");
  ASSERT_GE(thumb_ip, 0);
  ASSERT_GE(index_pip, 0);
  pose.joints[thumb_ip] = model.joints[thumb_ip].max;  // one at its upper limit, one at its lower
  pose.joints[index_pip] = model.joints[index_pip].min;
  EnergyTerms two;
  energy.evaluate(pose, nullptr, &two);
  EXPECT_NEAR(two.range_penalty, 0.5 + 0.25, 1e-9);
  EXPECT_NEAR(two.total, weightedTotal(params, two), 1e-9);
}

// The thumb's own weight (EnergyParams::thumb_range_weight) with the other joints' at 0: a long
// finger at its limit costs nothing, the thumb at its limit costs the thumb's weight.
TEST(Energy, TheThumbRangePriorHoldsOnlyTheThumb) {
  const HandModel model = loadHandModel(modelPath("sag"));
  EnergyParams params;
  ASSERT_EQ(params.joint_range_weight, 0.0);
  params.thumb_range_weight = 0.003;
  PoseEnergy energy(model, params);
  energy.setFrame(modelObservations(model, typicalPose(model), fiveCameraRig(), 6.0));
  Pose pose = midRangePose(model);
  for (const char* finger : {"index", "middle", "ring", "pinky"}) {
    const int pip = model.jointIndex(std::string(finger) + "_pip_flex");
    ASSERT_GE(pip, 0);
    pose.joints[pip] = model.joints[pip].max;
  }
  EnergyTerms fingers;
  energy.evaluate(pose, nullptr, &fingers);
  EXPECT_NEAR(fingers.range_penalty, 0.0, 1e-12);
  const int thumb_mcp = model.jointIndex("thumb_mcp_flex");
  ASSERT_GE(thumb_mcp, 0);
  pose.joints[thumb_mcp] = model.joints[thumb_mcp].min;
  EnergyTerms thumb;
  energy.evaluate(pose, nullptr, &thumb);
  EXPECT_NEAR(thumb.range_penalty, params.thumb_range_weight, 1e-12);
  EXPECT_NEAR(thumb.total, weightedTotal(params, thumb), 1e-9);
}

// The finger order prior: nothing for a spread hand or fingers turned toward each other by less
// than the margin; quadratic beyond it, per neighbouring pair; only the abductions matter.
TEST(Energy, FingerOrderPriorChargesNeighboursTurnedAcrossEachOther) {
  const HandModel model = loadHandModel(modelPath("sag"));
  EnergyParams params;
  PoseEnergy energy(model, params);
  energy.setFrame(modelObservations(model, typicalPose(model), fiveCameraRig(), 6.0));
  auto joint = [&model](const std::string& name) { return jointNamed(model, name); };
  Pose pose = typicalPose(model);
  // A spread hand, toward the thumb from the pinky to the index; then the index and middle
  // turned toward each other by just the margin.
  const double spread[] = {0.15, 0.05, -0.05, -0.15};
  const char* fingers[] = {"index", "middle", "ring", "pinky"};
  for (int f = 0; f < 4; ++f) pose.joints[joint(std::string(fingers[f]) + "_mcp_abd")] = spread[f];
  EnergyTerms spread_terms;
  energy.evaluate(pose, nullptr, &spread_terms);
  EXPECT_EQ(spread_terms.order_penalty, 0.0);
  pose.joints[joint("index_mcp_abd")] = 0.0;
  pose.joints[joint("middle_mcp_abd")] = params.finger_order_margin;
  EnergyTerms at_margin;
  energy.evaluate(pose, nullptr, &at_margin);
  EXPECT_EQ(at_margin.order_penalty, 0.0);
  // The stacked state of fingercount: index at its limit toward the middle, the middle toward the
  // index; and the ring across the middle as well. Curling a finger does not excuse it.
  pose.joints[joint("index_mcp_abd")] = -0.3;
  pose.joints[joint("middle_mcp_abd")] = 0.2;
  pose.joints[joint("ring_mcp_abd")] = 0.3;
  pose.joints[joint("ring_pip_flex")] = 1.5;
  EnergyTerms crossed;
  const double total = energy.evaluate(pose, nullptr, &crossed);
  const double m = params.finger_order_margin;
  const double expected = std::pow(0.5 - m, 2) + std::pow(0.1 - m, 2);  // ring-pinky: spread
  EXPECT_NEAR(crossed.order_penalty, expected, 1e-12);
  EXPECT_NEAR(total, weightedTotal(params, crossed), 1e-9);
  // Switched off, it costs nothing.
  const double weight = params.finger_order_weight;
  params.finger_order_weight = 0.0;
  PoseEnergy without(model, params);
  without.setFrame(modelObservations(model, typicalPose(model), fiveCameraRig(), 6.0));
  EnergyTerms unpriced;
  EXPECT_NEAR(without.evaluate(pose, nullptr, &unpriced), total + weight * expected, 1e-9);
  EXPECT_EQ(unpriced.order_penalty, 0.0);
}

// The fan-turn prior charges the long fingers' common sideways turn beyond its margin, not their
// spread: a fan opened or closed about the middle costs nothing.
TEST(Energy, FanTurnPriorChargesTheLongFingersTurnedTogether) {
  const HandModel model = loadHandModel(modelPath("sag"));
  EnergyParams params;
  params.fan_turn_weight = 1.0;
  PoseEnergy energy(model, params);
  energy.setFrame(modelObservations(model, typicalPose(model), fiveCameraRig(), 6.0));
  const char* fingers[] = {"index", "middle", "ring", "pinky"};
  auto withAbductions = [&](const std::array<double, 4>& abductions) {
    Pose pose = typicalPose(model);
    for (int f = 0; f < 4; ++f) {
      pose.joints[jointNamed(model, std::string(fingers[f]) + "_mcp_abd")] = abductions[f];
    }
    return pose;
  };
  auto penalty = [&](const Pose& pose, double* total = nullptr) {
    EnergyTerms terms;
    const double value = energy.evaluate(pose, nullptr, &terms);
    if (total) *total = value;
    EXPECT_NEAR(value, weightedTotal(params, terms), 1e-9);
    return terms.fan_turn_penalty;
  };
  EXPECT_EQ(penalty(withAbductions({0.3, 0.1, -0.1, -0.3})), 0.0);  // spread wide
  EXPECT_EQ(penalty(withAbductions({0.0, 0.0, 0.0, 0.0})), 0.0);    // closed
  EXPECT_EQ(penalty(withAbductions({0.2, 0.15, 0.12, 0.1})), 0.0);  // turned within the margin
  // All four turned toward the thumb (mean 0.3) and toward the pinky (mean -0.25).
  EXPECT_NEAR(penalty(withAbductions({0.35, 0.3, 0.3, 0.25})), std::pow(0.3 - 0.15, 2), 1e-12);
  double total = 0.0;
  const Pose turned = withAbductions({-0.2, -0.25, -0.3, -0.25});
  EXPECT_NEAR(penalty(turned, &total), std::pow(0.25 - 0.15, 2), 1e-12);
  // Switched off, it costs nothing.
  params.fan_turn_weight = 0.0;
  PoseEnergy without(model, params);
  without.setFrame(modelObservations(model, typicalPose(model), fiveCameraRig(), 6.0));
  EXPECT_NEAR(without.evaluate(turned), total + 1.0 * std::pow(0.1, 2), 1e-9);
}

// The finger collision prior (opt-in) charges a straight finger laid along its straight neighbour,
// not an open hand's fingers side by side, nor the same abductions with the finger curled.
TEST(Energy, FingerCollisionPriorChargesStackedStraightFingersOnly) {
  const HandModel model = loadHandModel(modelPath("sag"));
  EnergyParams params;
  ASSERT_EQ(params.finger_collision_weight, 0.0);  // opt-in
  params.finger_collision_weight = 0.1;
  PoseEnergy energy(model, params);
  energy.setFrame(modelObservations(model, typicalPose(model), fiveCameraRig(), 6.0));
  auto joint = [&model](const std::string& name) { return jointNamed(model, name); };
  const char* fingers[] = {"index", "middle", "ring", "pinky"};
  Pose pose = typicalPose(model);
  // Straight fingers side by side, not spread.
  for (const char* finger : fingers) {
    pose.joints[joint(std::string(finger) + "_mcp_abd")] = 0.0;
    pose.joints[joint(std::string(finger) + "_mcp_flex")] = 0.0;
    pose.joints[joint(std::string(finger) + "_pip_flex")] = 0.0;
    pose.joints[joint(std::string(finger) + "_dip_flex")] = 0.0;
  }
  EnergyTerms side_by_side;
  energy.evaluate(pose, nullptr, &side_by_side);
  EXPECT_EQ(side_by_side.collision_penalty, 0.0);
  // The middle finger turned onto the index, both straight (fingercount's stacked finger).
  pose.joints[joint("index_mcp_abd")] = -0.1;
  pose.joints[joint("middle_mcp_abd")] = 0.25;
  EnergyTerms stacked;
  const double total = energy.evaluate(pose, nullptr, &stacked);
  EXPECT_GT(stacked.collision_penalty, 0.05);  // measured 0.50
  EXPECT_NEAR(total, weightedTotal(params, stacked), 1e-9);
  // The same abductions with the middle finger curled: nothing.
  pose.joints[joint("middle_mcp_flex")] = 1.4;
  pose.joints[joint("middle_pip_flex")] = 1.6;
  EnergyTerms curled;
  energy.evaluate(pose, nullptr, &curled);
  EXPECT_LT(curled.collision_penalty, 0.1 * stacked.collision_penalty);  // measured 0
}

// The wrist prior charges a wrist away from where the sleeve meets the hand in the images: nothing
// within its tolerance, more the farther off, at most its weight (a far-off camera pulls
// little), nothing without evidence or with the forearm in the energy (a bare forearm).
TEST(Energy, WristPriorChargesAWristAwayFromTheSleevesEnd) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const EnergyParams params;
  ASSERT_GT(params.wrist_weight, 0.0);  // on by default
  PoseEnergy energy(model, params);
  const Pose truth = typicalPose(model);
  std::vector<CameraObservation> observations =
      modelObservations(model, truth, fiveCameraRig(), 6.0);
  addArmEvidenceAt(upTheArm(truth, 0.015), observations);
  energy.setFrame(observations);
  auto wristPenalty = [&](double along_the_hand) {
    Pose pose = truth;
    pose.translation += along_the_hand * truth.rotation.col(0);
    EnergyTerms terms;
    const double total = energy.evaluate(pose, nullptr, &terms);
    EXPECT_NEAR(total, weightedTotal(params, terms), 1e-9);
    return terms.wrist_penalty;
  };
  EXPECT_EQ(wristPenalty(0.0), 0.0);  // 1.5 cm off the rays at most: within the tolerance
  const double near = wristPenalty(0.03), off = wristPenalty(0.06), far = wristPenalty(0.3);
  EXPECT_GT(near, 0.0);
  EXPECT_GT(off, near);
  EXPECT_GT(far, off);
  EXPECT_LE(far, 1.0);
  EXPECT_GT(far, 0.99);  // bounded: a camera whose evidence lies far off adds a constant
  // The hand sliding 5 cm toward its fingers (the slide of a model smaller than the hand) now
  // costs more than a small share of the similarity.
  EXPECT_GT(params.wrist_weight * wristPenalty(0.05), 0.002);
  // No evidence (too few cells), or the forearm in the energy: nothing.
  for (CameraObservation& observation : observations) {
    observation.sog.arm_cells = params.wrist_min_cells - 1;
  }
  energy.setFrame(observations);
  EXPECT_EQ(wristPenalty(0.06), 0.0);
  addArmEvidenceAt(upTheArm(truth, 0.015), observations);
  energy.setFrame(observations);
  energy.setForearmPresent(true);
  EXPECT_EQ(wristPenalty(0.06), 0.0);
}

// The coupling prior: zero when every DIP is k times its PIP, quadratic in the residual.
TEST(Energy, PipDipCouplingPenalisesUncoupledDistalJoints) {
  const HandModel model = loadHandModel(modelPath("sag"));
  EnergyParams params;
  params.dip_pip_coupling_weight = 0.5;
  PoseEnergy energy(model, params);
  energy.setFrame(modelObservations(model, typicalPose(model), fiveCameraRig(), 6.0));
  Pose pose = typicalPose(model);
  auto joint = [&model](const std::string& name) { return jointNamed(model, name); };
  for (const std::string finger : {"index", "middle", "ring", "pinky"}) {
    pose.joints[joint(finger + "_pip_flex")] = 0.9;
    pose.joints[joint(finger + "_dip_flex")] = params.dip_pip_ratio * 0.9;
  }
  EnergyTerms coupled;
  energy.evaluate(pose, nullptr, &coupled);
  EXPECT_NEAR(coupled.coupling_penalty, 0.0, 1e-12);
  pose.joints[joint("ring_dip_flex")] += 0.3;  // one finger off by 0.3 rad
  EnergyTerms uncoupled;
  energy.evaluate(pose, nullptr, &uncoupled);
  EXPECT_NEAR(uncoupled.coupling_penalty, 0.09, 1e-12);
  EXPECT_NEAR(uncoupled.total,
              uncoupled.similarity - params.limit_weight * uncoupled.limit_penalty - 0.5 * 0.09 -
                  uncoupled.range_penalty,
              1e-12);
}

TEST(Energy, TruePoseScoresHigherThanPerturbedPoses) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const Pose truth = typicalPose(model);
  PoseEnergy energy(model, EnergyParams());
  energy.setFrame(modelObservations(model, truth, fiveCameraRig()));
  EnergyTerms terms;
  const double at_truth = energy.evaluate(truth, nullptr, &terms);
  EXPECT_GT(terms.similarity, 0.5);
  EXPECT_LE(terms.similarity, 1.0);
  EXPECT_EQ(terms.per_camera.size(), 5u);
  expectTruthBeatsNearbyPoses(energy, truth, at_truth);
}

// Issue 9: a pale or a dark hand is the model's hand in another colour. With the cast corrected
// the energy of every pose is what it is for the model's own colour; without, a uniform tint
// changes the energy's landscape (the pose ranking flips for a darker skin).
TEST(Energy, SkinToneDoesNotChangeTheEnergyOnceTheColourCastIsCorrected) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const Pose truth = typicalPose(model);
  const std::vector<CameraObservation> own = modelObservations(model, truth, fiveCameraRig());
  std::vector<CameraObservation> tinted = own;
  for (CameraObservation& observation : tinted) {
    for (ImageGaussian& g : observation.sog.gaussians) {
      g.hsv = Hsv(g.hsv[0] - 8.0, 0.5 * g.hsv[1], 0.45 * g.hsv[2]);  // darker, greyer, redder
    }
  }
  EnergyParams corrected, uncorrected;
  uncorrected.correct_colour_cast = false;
  PoseEnergy own_energy(model, corrected), tinted_energy(model, corrected),
      tinted_uncorrected(model, uncorrected);
  own_energy.setFrame(own);
  tinted_energy.setFrame(tinted);
  tinted_uncorrected.setFrame(tinted);
  std::mt19937 rng(7);
  for (int trial = 0; trial < 5; ++trial) {
    const Pose pose = randomPose(model, rng);
    EXPECT_NEAR(tinted_energy.evaluate(pose), own_energy.evaluate(pose), 1e-9);
  }
  EXPECT_NEAR(tinted_energy.evaluate(truth), own_energy.evaluate(truth), 1e-9);
  // Without the correction the tint costs similarity at the true pose.
  EXPECT_LT(tinted_uncorrected.evaluate(truth), own_energy.evaluate(truth) - 0.1);
}

TEST(Energy, LimitPenaltyIsQuadraticOutsideTheLimits) {
  const HandModel model = loadHandModel(modelPath("sag"));
  Pose pose = neutralPose(model, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity());
  EXPECT_EQ(limitPenalty(model, pose, nullptr), 0.0);
  pose.joints[3] = model.joints[3].max + 0.2;
  PoseVector gradient;
  EXPECT_NEAR(limitPenalty(model, pose, &gradient), 0.04, 1e-12);
  EXPECT_NEAR(gradient[kFirstJointDof + 3], 0.4, 1e-12);
  // w_l = 0.1 of paper eq. 9.
  EXPECT_DOUBLE_EQ(EnergyParams().limit_weight, 0.1);
}

TEST(Energy, EmptyFramesAndBadCamerasAreHandled) {
  const HandModel model = loadHandModel(modelPath("sag"));
  PoseEnergy energy(model, EnergyParams());
  energy.setFrame({});
  PoseVector gradient;
  EnergyTerms terms;
  // Without cameras the similarity is 0 and only the priors (limits, PIP-DIP coupling, the
  // joint ranges') remain.
  const double value = energy.evaluate(typicalPose(model), &gradient, &terms);
  EXPECT_EQ(terms.similarity, 0.0);
  EXPECT_DOUBLE_EQ(value, -EnergyParams().limit_weight * terms.limit_penalty -
                              EnergyParams().dip_pip_coupling_weight * terms.coupling_penalty -
                              terms.range_penalty);
  EXPECT_TRUE(gradient.allFinite());

  std::vector<Camera> cameras = fiveCameraRig();
  cameras[2].K(0, 0) = 0.0;
  try {
    energy.setFrame(modelObservations(model, typicalPose(model), {cameras[2]}));
    FAIL() << "zero focal length accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("focal length"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cam2"), std::string::npos) << e.what();
  }
}

TEST(Energy, PoseWithCameraInsideAGaussianStaysFinite) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  PoseEnergy energy(model, EnergyParams());
  energy.setFrame(modelObservations(model, typicalPose(model), cameras));
  // Put the hand over camera 0's centre: some Gaussians contain it, some are behind it.
  Pose pose = typicalPose(model);
  pose.translation = cameras[0].centre() - Eigen::Vector3d(0.03, 0.0, 0.0);
  PoseVector gradient;
  const double value = energy.evaluate(pose, &gradient);
  EXPECT_TRUE(std::isfinite(value));
  EXPECT_TRUE(gradient.allFinite());
}

// ---- an energy that cannot cheat (issue 11) -----------------------------------------------------

namespace {

// Camera 0's similarity and the total energy with the hand moved `distance` metres toward
// camera 0 along the line from the hand to the camera.
struct TowardCamera {
  double camera0 = 0.0;
  double total = 0.0;
};
TowardCamera moveTowardCamera0(const PoseEnergy& energy, const Pose& truth,
                               const std::vector<Camera>& cameras, double distance) {
  Pose moved = truth;
  const Eigen::Vector3d to_camera = (cameras[0].centre() - truth.translation).normalized();
  moved.translation += distance * to_camera;
  EnergyTerms terms;
  TowardCamera out;
  out.total = energy.evaluate(moved, nullptr, &terms);
  out.camera0 = terms.per_camera[0] * terms.per_camera.size();  // undo the mean over cameras
  return out;
}

// An energy with normalisation lambda (EnergyParams::model_area_weight) on `observations`.
PoseEnergy energyWithAreaWeight(const HandModel& model,
                                const std::vector<CameraObservation>& observations,
                                double model_area_weight) {
  EnergyParams params;
  params.model_area_weight = model_area_weight;
  PoseEnergy energy(model, params);
  energy.setFrame(observations);
  return energy;
}

}  // namespace

// The paper's normalisation (model_area_weight 0) rewards a hand that comes closer to one camera:
// its projection grows and saturates more image Gaussians. With the model's area in the
// denominator (model_area_weight 1), coming closer only costs.
TEST(EnergyCannotCheat, MovingTowardACameraDoesNotBuySimilarity) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  const Pose truth = typicalPose(model);
  const auto observations = modelObservations(model, truth, cameras);
  const PoseEnergy paper_energy = energyWithAreaWeight(model, observations, 0.0);
  const PoseEnergy energy = energyWithAreaWeight(model, observations, 1.0);

  const TowardCamera paper_at_truth = moveTowardCamera0(paper_energy, truth, cameras, 0.0);
  const TowardCamera at_truth = moveTowardCamera0(energy, truth, cameras, 0.0);
  for (double distance : {0.1, 0.2, 0.3}) {
    const TowardCamera paper_moved = moveTowardCamera0(paper_energy, truth, cameras, distance);
    const TowardCamera moved = moveTowardCamera0(energy, truth, cameras, distance);
    // The cheat of the paper's normalisation: camera 0 likes the closer hand.
    EXPECT_GT(paper_moved.camera0, paper_at_truth.camera0) << distance;
    // Ours: camera 0 likes it less, and so does the total.
    EXPECT_LT(moved.camera0, at_truth.camera0) << distance;
    EXPECT_LT(moved.total, at_truth.total) << distance;
  }
}

// The tracker scores its starts with another lambda than its tracking
// (TrackerParams::start_model_area_weight): set on an energy, lambda scores exactly as an energy
// built with it, and moving toward a camera then costs as above.
TEST(EnergyCannotCheat, ModelAreaWeightSetOnAnEnergyScoresAsOneBuiltWithIt) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  const Pose truth = typicalPose(model);
  const auto observations = modelObservations(model, truth, cameras);
  const PoseEnergy built = energyWithAreaWeight(model, observations, 1.0);
  PoseEnergy set = energyWithAreaWeight(model, observations, EnergyParams().model_area_weight);
  const double paper_at_truth = set.evaluate(truth);
  set.setModelAreaWeight(1.0);
  for (double distance : {0.0, 0.1, 0.2}) {
    const TowardCamera from_built = moveTowardCamera0(built, truth, cameras, distance);
    const TowardCamera from_set = moveTowardCamera0(set, truth, cameras, distance);
    EXPECT_DOUBLE_EQ(from_set.total, from_built.total) << distance;
    EXPECT_DOUBLE_EQ(from_set.camera0, from_built.camera0) << distance;
  }
  EXPECT_NE(set.evaluate(truth), paper_at_truth);
  set.setModelAreaWeight(0.0);
  EXPECT_DOUBLE_EQ(set.evaluate(truth), paper_at_truth);
  EXPECT_THROW(set.setModelAreaWeight(-0.5), InputError);
  EXPECT_THROW(set.setModelAreaWeight(std::nan("")), InputError);
}

// The tracker refines curled hands with occlusion switched on for a few iterations
// (TrackerParams::curled_refine_*): an energy whose occlusion is set scores and climbs as one built
// with it, and set back to 0 as the paper's again.
TEST(Energy, OcclusionSetOnAnEnergyScoresAsOneBuiltWithIt) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  Pose fist = typicalPose(model);
  for (const LongFingerJoints& finger : longFingerJoints(model)) {
    fist.joints[finger.mcp_flex] = 1.3;  // fingers in front of the palm: occlusion counts
    fist.joints[finger.pip_flex] = 1.5;
  }
  const auto observations = modelObservations(model, fist, cameras);
  EnergyParams occluding;
  occluding.occlusion_depth_scale = 0.01;
  PoseEnergy built(model, occluding);
  built.setFrame(observations);
  PoseEnergy set(model, EnergyParams());
  set.setFrame(observations);
  const double paper = set.evaluate(fist);
  set.setOcclusionDepthScale(0.01);
  PoseVector built_gradient, set_gradient;
  EXPECT_DOUBLE_EQ(set.evaluate(fist, &set_gradient), built.evaluate(fist, &built_gradient));
  EXPECT_TRUE(set_gradient.isApprox(built_gradient));
  EXPECT_NE(set.evaluate(fist), paper);
  set.setOcclusionDepthScale(0.0);
  EXPECT_DOUBLE_EQ(set.evaluate(fist), paper);
  EXPECT_THROW(set.setOcclusionDepthScale(-0.01), InputError);
  EXPECT_THROW(set.setOcclusionDepthScale(std::nan("")), InputError);
}

// Model Gaussians that cannot be projected into a camera that sees foreground (behind it, or
// containing its centre) count against the pose (model_area_weight 1), and a hand behind a camera
// scores nothing there.
TEST(EnergyCannotCheat, GaussiansBehindACameraCountAgainstThePose) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  const Pose truth = typicalPose(model);
  EnergyParams dice;
  dice.model_area_weight = 1.0;
  PoseEnergy energy(model, dice);
  energy.setFrame(modelObservations(model, truth, cameras));
  EnergyTerms terms;
  energy.evaluate(truth, nullptr, &terms);
  EXPECT_EQ(terms.invalid_projections, 0);

  // The hand 0.5 m behind camera 0 (on the line from the workspace through the camera).
  Pose behind = truth;
  const Eigen::Vector3d out = (cameras[0].centre() - truth.translation).normalized();
  behind.translation = cameras[0].centre() + 0.5 * out;
  EnergyTerms behind_terms;
  energy.evaluate(behind, nullptr, &behind_terms);
  EXPECT_GE(behind_terms.invalid_projections, static_cast<int>(model.gaussians.size()));
  EXPECT_EQ(behind_terms.per_camera[0], 0.0);
  EXPECT_LT(behind_terms.similarity, 0.25 * terms.similarity);
  EXPECT_FALSE(isInFrontOfCameras(behind.translation, cameras));
  EXPECT_TRUE(isInFrontOfCameras(truth.translation, cameras));
}

TEST(EnergyCannotCheat, InFrontOfCamerasNeedsEveryCamera) {
  const std::vector<Camera> cameras = fiveCameraRig();
  const Eigen::Vector3d centre(0.0, 0.0, 0.15);
  EXPECT_TRUE(isInFrontOfCameras(centre, cameras));
  // Just behind camera 2, seen from the workspace: in front of the others, not of camera 2.
  const Eigen::Vector3d behind2 =
      cameras[2].centre() + 0.1 * (cameras[2].centre() - centre).normalized();
  EXPECT_FALSE(isInFrontOfCameras(behind2, cameras));
  EXPECT_TRUE(isInFrontOfCameras(behind2, {cameras[0]}));
  // min_depth: 5 cm in front of camera 2 passes 0.04 and fails 0.06.
  const Eigen::Vector3d near2 =
      cameras[2].centre() + 0.05 * (centre - cameras[2].centre()).normalized();
  EXPECT_TRUE(isInFrontOfCameras(near2, {cameras[2]}, 0.04));
  EXPECT_FALSE(isInFrontOfCameras(near2, {cameras[2]}, 0.06));
  std::vector<CameraObservation> observations(1);
  observations[0].camera = cameras[2];
  EXPECT_FALSE(isInFrontOfCameras(behind2, observations));
  EXPECT_THROW(
      {
        EnergyParams bad;
        bad.model_area_weight = -1.0;
        PoseEnergy(loadHandModel(modelPath("sag")), bad);
      },
      InputError);
}

// The float pair kernels (the default, EnergyParams::float_pairs) give the double energy and
// gradient to float's precision, with every term on: soft saturation, occlusion, the forearm,
// the default cut-off.
TEST(Energy, FloatPairsAgreeWithDoublePairs) {
  const HandModel model = loadHandModel(modelPath("sag"));
  EnergyParams params;
  params.occlusion_depth_scale = 0.005;
  params.model_area_weight = 0.5;
  ASSERT_TRUE(params.float_pairs);
  PoseEnergy in_float(model, params);
  params.float_pairs = false;
  PoseEnergy in_double(model, params);
  const std::vector<CameraObservation> observations =
      modelObservations(withForearm(model, params), typicalPose(model), fiveCameraRig(), 6.0);
  for (PoseEnergy* energy : {&in_float, &in_double}) {
    energy->setFrame(observations);
    energy->setForearmPresent(true);
  }
  std::mt19937 rng(11);
  for (int trial = 0; trial < 6; ++trial) {
    const Pose pose = trial == 0 ? typicalPose(model) : randomPose(model, rng);
    PoseVector g_float, g_double;
    const double e_float = in_float.evaluate(pose, &g_float);
    const double e_double = in_double.evaluate(pose, &g_double);
    ASSERT_GT(std::fabs(e_double), 0.0);
    EXPECT_NEAR(e_float, e_double, 1e-5 * std::fabs(e_double)) << "trial " << trial;
    // Each component to 1e-4 of the gradient's largest one: the optimiser steps by sign (Rprop)
    // and by group norm (fixed steps).
    const double scale = g_double.cwiseAbs().maxCoeff();
    for (int i = 0; i < kNumDof; ++i) {
      EXPECT_NEAR(g_float[i], g_double[i], 1e-4 * scale)
          << "trial " << trial << " parameter " << model.parameterNames()[i];
    }
  }
}

// ---- the forearm (issue 9) ----------------------------------------------------------------------

namespace {

// The gradient with the forearm present, rigid with the hand (no direction) or along a world
// direction of its own, on images of the hand with a bare forearm.
void checkForearmGradient(const std::optional<Eigen::Vector3d>& direction) {
  const HandModel model = loadHandModel(modelPath("sag"));
  EnergyParams params;
  params.max_mahalanobis_sq = 1e9;
  params.float_pairs = false;
  PoseEnergy energy(model, params);
  energy.setFrame(
      modelObservations(withForearm(model, params), typicalPose(model), fiveCameraRig(), 6.0));
  energy.setForearmPresent(true);
  energy.setForearmDirection(direction);
  ASSERT_TRUE(energy.forearmPresent());
  std::mt19937 rng(7);
  for (int trial = 0; trial < 3; ++trial) {
    expectGradientMatches(energy, model, randomPose(model, rng), "trial " + std::to_string(trial));
  }
}

}  // namespace

TEST(EnergyGradient, SagWithARigidForearmMatchesCentralDifferences) {
  checkForearmGradient(std::nullopt);
}
TEST(EnergyGradient, SagWithAForearmOfItsOwnDirectionMatchesCentralDifferences) {
  checkForearmGradient(Eigen::Vector3d(-0.9, 0.3, -0.2));
}

// Until the forearm is declared present the energy is the hand's alone, value and gradient.
TEST(Energy, ForearmIsAbsentByDefaultAndThenChangesNothing) {
  const HandModel model = loadHandModel(modelPath("sag"));
  EnergyParams with_arm, without_arm;
  without_arm.forearm_gaussians = 0;
  ASSERT_GT(with_arm.forearm_gaussians, 0);
  PoseEnergy a(model, with_arm), b(model, without_arm);
  const auto observations =
      modelObservations(withForearm(model, with_arm), typicalPose(model), fiveCameraRig());
  a.setFrame(observations);
  b.setFrame(observations);
  EXPECT_FALSE(a.forearmPresent());
  b.setForearmPresent(true);  // no Gaussians: nothing to add
  EXPECT_FALSE(b.forearmPresent());
  std::mt19937 rng(3);
  for (int trial = 0; trial < 3; ++trial) {
    const Pose pose = randomPose(model, rng);
    PoseVector ga, gb;
    EXPECT_EQ(a.evaluate(pose, &ga), b.evaluate(pose, &gb));
    EXPECT_EQ(ga, gb);
  }
}

// A bare forearm is foreground the hand cannot explain: the forearm adds much similarity there
// (the tracker's forearm_min_gain switches it on), little on a hand whose forearm is sleeved
// (background), and with it the true pose beats the hand slid up onto the arm.
TEST(Energy, ForearmExplainsABareForearmAndLittleElse) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const EnergyParams params;
  const TrackerParams tracker_defaults;
  Pose truth = typicalPose(model);
  for (int j = 0; j < kNumJointDof; ++j) truth.joints[j] = model.joints[j].max * 0.8;  // a fist
  const Eigen::Vector3d straight = -truth.rotation.col(0);

  PoseEnergy bare(model, params), sleeved(model, params);
  bare.setFrame(modelObservations(withForearm(model, params), truth, fiveCameraRig()));
  sleeved.setFrame(modelObservations(model, truth, fiveCameraRig()));
  const double bare_gain = bare.evaluateWithForearm(truth, straight) - bare.evaluate(truth);
  const double sleeved_gain =
      sleeved.evaluateWithForearm(truth, straight) - sleeved.evaluate(truth);
  EXPECT_GT(bare_gain, tracker_defaults.forearm_min_gain);
  EXPECT_LT(sleeved_gain, 0.5 * tracker_defaults.forearm_min_gain);
  EXPECT_GE(sleeved_gain, 0.0);

  Pose slid = truth;
  slid.translation -= 0.04 * truth.rotation.col(0);  // 4 cm up the arm
  bare.setForearmPresent(true);
  EXPECT_GT(bare.evaluate(truth), bare.evaluate(slid) + 0.01);
}

TEST(Energy, BadForearmParametersAreRefused) {
  const HandModel model = loadHandModel(modelPath("sag"));
  auto with = [&model](auto change) {
    EnergyParams params;
    change(&params);
    return [model, params]() { PoseEnergy energy(model, params); };
  };
  EXPECT_THROW(with([](EnergyParams* p) { p->forearm_sigma = 0.0; })(), InputError);
  EXPECT_THROW(with([](EnergyParams* p) { p->forearm_gaussians = -1; })(), InputError);
  EXPECT_THROW(with([](EnergyParams* p) { p->forearm_length = std::nan(""); })(), InputError);
  EXPECT_THROW(with([](EnergyParams* p) { p->forearm_weight = -1.0; })(), InputError);
  // No forearm: its other parameters do not matter.
  EXPECT_NO_THROW(with([](EnergyParams* p) {
    p->forearm_gaussians = 0;
    p->forearm_sigma = 0.0;
  })());
}
