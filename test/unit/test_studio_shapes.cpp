// Tests of issue 9's studio additions: named hand shapes (proportions and skin tones), the bare
// forearm, and the harder motions (raised, pronation, wristflex, fastturn).
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <opencv2/core.hpp>
#include <set>
#include <string>
#include <vector>

#include "sag_hand_tracker/apps/metrics.h"
#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/energy/colour.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/studio/hand_shapes.h"
#include "sag_hand_tracker/studio/hand_surface.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/studio/renderer.h"
#include "sag_hand_tracker/studio/sequence.h"
#include "test_support/temp_files.h"

using namespace sag_hand_tracker;
using namespace sag_hand_tracker::studio;

namespace {

const std::string kConfig = std::string(SAG_SOURCE_DIR) + "/config";

const HandModel& handModel() {
  static const HandModel model = loadHandModel(resolveModelPath("sag", kConfig));
  return model;
}

const std::vector<Camera>& dexter5() {
  static const std::vector<Camera> cameras =
      loadCameraRig(kConfig + "/rigs/dexter5/rig.yaml").cameras;
  return cameras;
}

const std::vector<StudioHand>& configHands() {
  static const std::vector<StudioHand> hands = loadHandShapes(handShapesPath(kConfig));
  return hands;
}

// An open hand, tilted so that the cameras see it from different sides.
Pose openHandPose() {
  Pose pose;
  pose.translation = Eigen::Vector3d(0.0, -0.06, 0.15);
  pose.rotation = motionOrientation(Eigen::Vector3d(15, -10, 0));
  const auto names = handModel().parameterNames();
  const std::map<std::string, double> joints{{"thumb_cmc_abd", 30},
                                             {"thumb_mcp_flex", 5},
                                             {"index_mcp_abd", 15},
                                             {"ring_mcp_abd", -10},
                                             {"pinky_mcp_abd", -18}};
  for (int j = 0; j < kNumJointDof; ++j) {
    const auto it = joints.find(names[kFirstJointDof + j]);
    pose.joints[j] = it == joints.end() ? 0.0 : it->second * M_PI / 180.0;
    pose.joints[j] =
        std::clamp(pose.joints[j], handModel().joints[j].min, handModel().joints[j].max);
  }
  return pose;
}

std::string expectInputError(const std::string& yaml) {
  try {
    parseHandShapes(yaml, "test.yaml");
  } catch (const InputError& error) {
    return error.what();
  }
  ADD_FAILURE() << "no error for:\n" << yaml;
  return "";
}

}  // namespace

// ---- hand shapes ------------------------------------------------------------------------------

TEST(StudioShapes, ConfigHasTheDefaultAndAtLeastSixOtherHandsWithinTheIssuesRanges) {
  const auto& hands = configHands();
  ASSERT_GE(hands.size(), 7u);
  EXPECT_EQ(hands.front().name, "default");
  const StudioHand reference;
  EXPECT_EQ(hands.front().shape.scale, 1.0);
  EXPECT_EQ(hands.front().skin.dorsal, reference.skin.dorsal);
  int other_skin = 0, darker = 0;
  for (const StudioHand& hand : hands) {
    SCOPED_TRACE(hand.name);
    const HandShape& s = hand.shape;
    // Bone lengths and palm width within +-15 % (the long distal phalanges of the independent
    // set's proportions aside), thickness within +-20 %.
    EXPECT_GE(s.scale * s.palm_width, 0.85 - 1e-9);
    EXPECT_LE(s.scale * s.palm_width, 1.15 + 1e-9);
    EXPECT_GE(s.thickness, 0.8 - 1e-9);
    EXPECT_LE(s.thickness, 1.2 + 1e-9);
    for (int f = 0; f < kNumFingers; ++f) {
      for (int k = 0; k < 2; ++k) {
        EXPECT_GE(s.boneFactor(f, k), 0.85 * 0.8 - 1e-9);  // the short proximal phalanges
        EXPECT_LE(s.boneFactor(f, k), 1.3);
      }
    }
    if (hand.skin.dorsal != reference.skin.dorsal) ++other_skin;
    if (hand.skin.dorsal.sum() < 0.5 * reference.skin.dorsal.sum()) ++darker;
  }
  EXPECT_GE(other_skin, 5);
  EXPECT_GE(darker, 1);
  // The independent set's proportions are there: proximal ~20 % shorter, distal ~50 % longer.
  const StudioHand long_distal = resolveHandShape("long_distal", kConfig);
  EXPECT_NEAR(long_distal.shape.phalanx_length[1][0], 0.8, 1e-12);
  EXPECT_NEAR(long_distal.shape.phalanx_length[1][2], 1.5, 1e-12);
}

TEST(StudioShapes, BoneLengthsAndOffsetsFollowTheFactors) {
  const HandModel& model = handModel();
  const auto chains = fingerChains(model);
  for (const StudioHand& hand : configHands()) {
    SCOPED_TRACE(hand.name);
    const HandShape& shape = hand.shape;
    const HandModel shaped = shapeHandModel(model, shape);
    ASSERT_EQ(shaped.bones.size(), model.bones.size());
    for (int f = 0; f < kNumFingers; ++f) {
      for (int k = 0; k < 3; ++k) {
        const int b = chains[f][k];
        EXPECT_NEAR(shaped.bones[b].length, model.bones[b].length * shape.boneFactor(f, k), 1e-12)
            << fingerNames()[f] << " bone " << k;
        if (k == 0) {  // on the palm: along and across it, then moved by the layout
          const Eigen::Vector3d shift = shape.scale * shape.knuckle_shift[f];
          EXPECT_NEAR(shaped.bones[b].offset.x(),
                      model.bones[b].offset.x() * shape.scale * shape.palm_length + shift.x(),
                      1e-12);
          EXPECT_NEAR(shaped.bones[b].offset.y(),
                      model.bones[b].offset.y() * shape.scale * shape.palm_width + shift.y(),
                      1e-12);
        } else {  // a joint sits at the end of its parent bone
          EXPECT_NEAR(shaped.bones[b].offset.norm(), shaped.bones[chains[f][k - 1]].length, 1e-12);
        }
      }
    }
  }
  // One phalanx alone: the index's distal bone 1.5 times longer moves the index tip only, by
  // half the distal bone's length when the finger is straight.
  HandShape shape;
  shape.phalanx_length[1][2] = 1.5;
  const HandModel shaped = shapeHandModel(model, shape);
  Pose pose;
  for (int j = 0; j < kNumJointDof; ++j) {
    pose.joints[j] = std::clamp(0.0, model.joints[j].min, model.joints[j].max);
  }
  const auto base = boneFingertips(model, forwardKinematics(model, pose).bone_frames);
  const auto tips = boneFingertips(shaped, forwardKinematics(shaped, pose).bone_frames);
  const double distal = model.bones[chains[1][2]].length;
  EXPECT_NEAR((tips[1] - base[1]).norm(), 0.5 * distal, 1e-9);
  for (int f : {0, 2, 3, 4}) EXPECT_LT((tips[f] - base[f]).norm(), 1e-12) << fingerNames()[f];
  shape.phalanx_length[1][2] = 0.0;
  EXPECT_THROW(shapeHandModel(model, shape), InputError);
  shape.phalanx_length[1][2] = 1.0;
  shape.palm_length = std::nan("");
  EXPECT_THROW(shapeHandModel(model, shape), InputError);
}

// The skeleton's layout (session 41): knuckles moved on the palm, fingers turned at rest, curls
// tilted sideways. Each does what it says and nothing else, and the config has hands with it.
TEST(StudioShapes, TheSkeletonsLayoutMovesKnucklesTurnsFingersAndTiltsTheirCurl) {
  const HandModel& model = handModel();
  const auto chains = fingerChains(model);
  const auto parameter = [&](const std::string& name) {
    const auto names = model.parameterNames();
    return static_cast<int>(std::find(names.begin(), names.end(), name) - names.begin()) -
           kFirstJointDof;
  };
  Pose open;
  for (int j = 0; j < kNumJointDof; ++j) {
    open.joints[j] = std::clamp(0.0, model.joints[j].min, model.joints[j].max);
  }
  const auto tipsOf = [&](const HandModel& m, const Pose& pose) {
    return boneFingertips(m, forwardKinematics(m, pose).bone_frames);
  };
  const auto base = tipsOf(model, open);

  // The index's knuckle moved by (-3, 2, -1) mm at size 1.1: its tip moves by 1.1 times that.
  HandShape moved;
  moved.scale = 1.1;
  moved.knuckle_shift[1] = Eigen::Vector3d(-0.003, 0.002, -0.001);
  HandShape sized;
  sized.scale = 1.1;
  const auto sized_tips = tipsOf(shapeHandModel(model, sized), open);
  const auto moved_tips = tipsOf(shapeHandModel(model, moved), open);
  EXPECT_LT((moved_tips[1] - sized_tips[1] - 1.1 * moved.knuckle_shift[1]).norm(), 1e-12);
  for (int f : {0, 2, 3, 4}) EXPECT_LT((moved_tips[f] - sized_tips[f]).norm(), 1e-12);

  // The ring turned by 10 degrees of yaw at rest: the straight finger points 10 degrees off.
  HandShape turned;
  turned.base_rotation[3] = Eigen::Vector3d(0.0, 0.0, 10.0 * M_PI / 180.0);
  const HandModel turned_model = shapeHandModel(model, turned);
  const PosedHand posed = forwardKinematics(model, open);
  const Eigen::Vector3d knuckle = posed.bone_frames[chains[3][0]].translation();
  const auto turned_tips = tipsOf(turned_model, open);
  EXPECT_NEAR(
      std::acos((base[3] - knuckle).normalized().dot((turned_tips[3] - knuckle).normalized())),
      10.0 * M_PI / 180.0, 1e-9);
  EXPECT_NEAR((turned_tips[3] - knuckle).norm(), (base[3] - knuckle).norm(), 1e-12);

  // The little finger's curl tilted by -10 degrees: open, nothing changes; curled (MCP and PIP at
  // 80 degrees), its tip leaves the plane the untilted finger curls in, toward the side the
  // tilt's sign says, by as much as the opposite tilt the other way; its bones keep their lengths.
  Pose curled = open;
  for (const char* joint : {"pinky_mcp_flex", "pinky_pip_flex", "pinky_dip_flex"}) {
    curled.joints[parameter(joint)] = 80.0 * M_PI / 180.0;
  }
  const PosedHand curled_frames = forwardKinematics(model, curled);
  const Eigen::Isometry3d& rest = curled_frames.bone_frames[chains[4][0]];
  // The plane of the untilted curl: the proximal bone's rest y axis is its normal (MCP flexion
  // turns about it), so measure the tip's offset along the palm frame's image of that axis.
  const Eigen::Vector3d side = (posed.bone_frames[chains[4][0]].linear().col(1)).normalized();
  const Eigen::Vector3d pinky_knuckle = rest.translation();
  const auto sideways = [&](double tilt_deg, const Pose& pose) {
    HandShape tilted;
    tilted.flexion_tilt[4] = tilt_deg * M_PI / 180.0;
    const HandModel m = shapeHandModel(model, tilted);
    const PosedHand frames = forwardKinematics(m, pose);
    for (int k = 0; k < 2; ++k) {  // the joints stay a bone length apart
      EXPECT_NEAR((frames.bone_frames[chains[4][k + 1]].translation() -
                   frames.bone_frames[chains[4][k]].translation())
                      .norm(),
                  model.bones[chains[4][k]].length, 1e-12);
    }
    return (boneFingertips(m, frames.bone_frames)[4] - pinky_knuckle).dot(side);
  };
  EXPECT_NEAR(sideways(0.0, curled), 0.0, 1e-12);
  const double minus = sideways(-10.0, curled), plus = sideways(10.0, curled);
  EXPECT_GT(std::abs(minus), 0.004);  // metres: a visible shift for a 6 cm finger
  EXPECT_NEAR(minus, -plus, 1e-12);
  HandShape tilted;
  tilted.flexion_tilt[4] = -10.0 * M_PI / 180.0;
  EXPECT_LT((tipsOf(shapeHandModel(model, tilted), open)[4] - base[4]).norm(), 1e-12);

  // Non-finite layouts are refused.
  HandShape bad;
  bad.base_rotation[0].x() = std::nan("");
  EXPECT_THROW(shapeHandModel(model, bad), InputError);

  // The file: millimetres and degrees in, metres and radians out; bounds and lists checked.
  const auto hands = parseHandShapes(
      "shapes:\n  - {name: a, knuckle_shift_mm: {ring: [-3, 0, -4]},"
      " base_rotation_deg: {thumb: [10, 0, -8]}, flexion_tilt_deg: [0, 6, 2, -4, -8]}\n",
      "t");
  ASSERT_EQ(hands.size(), 1u);
  EXPECT_LT((hands[0].shape.knuckle_shift[3] - Eigen::Vector3d(-0.003, 0.0, -0.004)).norm(), 1e-15);
  EXPECT_EQ(hands[0].shape.knuckle_shift[1], Eigen::Vector3d::Zero());
  EXPECT_NEAR(hands[0].shape.base_rotation[0].z(), -8.0 * M_PI / 180.0, 1e-15);
  EXPECT_NEAR(hands[0].shape.flexion_tilt[4], -8.0 * M_PI / 180.0, 1e-15);
  EXPECT_NE(expectInputError("shapes:\n  - {name: a, knuckle_shift_mm: {index: [20, 0, 0]}}\n")
                .find("knuckle_shift_mm index = 20 mm is outside [-15, 15]"),
            std::string::npos);
  EXPECT_NE(expectInputError("shapes:\n  - {name: a, base_rotation_deg: {index: [0, 0]}}\n")
                .find("list of 3"),
            std::string::npos);
  EXPECT_NE(expectInputError("shapes:\n  - {name: a, base_rotation_deg: {toe: [0, 0, 0]}}\n")
                .find("'toe'"),
            std::string::npos);
  EXPECT_NE(expectInputError("shapes:\n  - {name: a, flexion_tilt_deg: [0, 0, 0, 0, 25]}\n")
                .find("outside [-20, 20]"),
            std::string::npos);

  // The config has hands on a skeleton of their own, one with the model's proportions.
  int own_layout = 0;
  for (const StudioHand& hand : configHands()) {
    double layout = 0.0;
    for (int f = 0; f < kNumFingers; ++f) {
      layout += hand.shape.knuckle_shift[f].norm() + hand.shape.base_rotation[f].norm() +
                std::abs(hand.shape.flexion_tilt[f]);
    }
    if (layout > 0.0) ++own_layout;
  }
  EXPECT_GE(own_layout, 2);
  EXPECT_EQ(resolveHandShape("other_skeleton", kConfig).shape.scale, 1.0);
}

TEST(StudioShapes, RenderedFingertipsAreTheGroundTruthOnEveryShape) {
  const HandModel& model = handModel();
  const StudioRenderer renderer(dexter5());
  const Pose pose = openHandPose();
  for (const StudioHand& hand : configHands()) {
    SCOPED_TRACE(hand.name);
    const HandModel shaped = shapeHandModel(model, hand.shape);
    const PosedHand posed = forwardKinematics(shaped, pose);
    const auto tips = boneFingertips(shaped, posed.bone_frames);
    HandSurfaceParams surface;
    surface.skin = hand.skin;
    const auto parts = buildHandSurface(shaped, posed.bone_frames, surface, hand.shape);
    const auto chains = fingerChains(shaped);
    // The distal capsule ends exactly at the ground-truth fingertip.
    for (int f = 0; f < kNumFingers; ++f) {
      for (const SurfacePart& part : parts) {
        if (part.label != fingerBoneLabel(f, 2)) continue;
        EXPECT_NEAR(signedDistance(part.cone, tips[f]), 0.0, 1e-12) << fingerNames()[f];
        const Eigen::Vector3d x = posed.bone_frames[chains[f][2]].linear().col(0);
        EXPECT_GT(signedDistance(part.cone, tips[f] + 1e-5 * x), 0.0);
      }
    }
    // In the images: pixels of each finger's distal phalanx within 2 px of its projected tip in
    // most views (a tip can be hidden in one or two).
    const auto images = renderer.render({parts}, 3);
    for (int f = 0; f < kNumFingers; ++f) {
      int seen = 0;
      for (size_t c = 0; c < images.size(); ++c) {
        const Camera& camera = dexter5()[c];
        const Eigen::Vector2d px = (camera.K * (camera.world_to_camera * tips[f])).hnormalized();
        bool near = false;
        for (int dv = -2; dv <= 2 && !near; ++dv) {
          for (int du = -2; du <= 2 && !near; ++du) {
            const int u = static_cast<int>(std::lround(px.x())) + du;
            const int v = static_cast<int>(std::lround(px.y())) + dv;
            if (u < 0 || v < 0 || u >= camera.width || v >= camera.height) continue;
            near = images[c].labels.at<std::uint8_t>(v, u) == fingerBoneLabel(f, 2);
          }
        }
        seen += near ? 1 : 0;
      }
      EXPECT_GE(seen, 3) << fingerNames()[f];
    }
  }
}

TEST(StudioShapes, SkinTonesChangeTheRenderedColour) {
  const HandModel& model = handModel();
  const StudioRenderer renderer(dexter5());
  const Pose pose = openHandPose();
  // Mean sRGB value and hue of the back of the hand in the top camera (cam4, looking down).
  auto skin = [&](const std::string& name) {
    const StudioHand hand = resolveHandShape(name, kConfig);
    const HandModel shaped = shapeHandModel(model, hand.shape);
    HandSurfaceParams surface;
    surface.skin = hand.skin;
    const auto parts =
        buildHandSurface(shaped, forwardKinematics(shaped, pose).bone_frames, surface, hand.shape);
    const StudioImage image = renderer.renderCamera(4, {parts}, 5);
    double value = 0.0, hue = 0.0;
    int n = 0;
    for (int v = 0; v < image.rgb.rows; ++v) {
      for (int u = 0; u < image.rgb.cols; ++u) {
        if (image.labels.at<std::uint8_t>(v, u) != kLabelPalm) continue;
        const cv::Vec3b p = image.rgb.at<cv::Vec3b>(v, u);
        const Hsv hsv = rgbToHsv(p[0], p[1], p[2]);
        value += hsv[2];
        hue += hsv[0] > 180.0 ? hsv[0] - 360.0 : hsv[0];
        ++n;
      }
    }
    EXPECT_GT(n, 200) << name;
    return std::make_pair(value / std::max(n, 1), hue / std::max(n, 1));
  };
  const auto reference = skin("default");
  const auto dark = skin("dark_small");
  const auto olive = skin("long_distal");
  EXPECT_LT(dark.first, reference.first - 0.2);     // much darker
  EXPECT_GT(olive.second, reference.second + 5.0);  // yellower
}

TEST(StudioShapes, LoadingAndRenderingAreDeterministic) {
  EXPECT_EQ(handShapeNames(kConfig), handShapeNames(kConfig));
  const StudioHand a = resolveHandShape("stocky", kConfig);
  const StudioHand b = resolveHandShape("stocky", kConfig);
  EXPECT_EQ(a.shape.finger_length, b.shape.finger_length);
  EXPECT_EQ(a.skin.dorsal, b.skin.dorsal);
  SequenceParams params;
  params.shape = a.shape;
  params.surface.skin = a.skin;
  params.frames = 40;
  const Motion motion = loadMotion(resolveMotionPath("pronation", kConfig), handModel(), 1);
  const StudioSequence one(handModel(), motion, params), two(handModel(), motion, params);
  const StudioRenderer renderer(dexter5());
  const StudioImage x = renderer.renderCamera(1, one.surfaces(30), one.noiseSeed(30));
  const StudioImage y = renderer.renderCamera(1, two.surfaces(30), two.noiseSeed(30));
  EXPECT_EQ(cv::norm(x.rgb, y.rgb, cv::NORM_INF), 0.0);
  for (int f = 0; f < kNumFingers; ++f) {
    EXPECT_EQ(one.frame(30).fingertips[f], two.frame(30).fingertips[f]);
  }
}

TEST(StudioShapes, ResolvesNamesAndFilesAndRejectsBadOnes) {
  EXPECT_EQ(resolveHandShape("default", kConfig).name, "default");
  EXPECT_EQ(resolveHandShape("default", "/nonexistent").name, "default");  // always known
  try {
    resolveHandShape("no_such_hand", kConfig);
    ADD_FAILURE() << "no error";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("long_distal"), std::string::npos) << error.what();
  }
  EXPECT_THROW(resolveHandShape("/nonexistent/shape.yaml", kConfig), InputError);
  // A shapes file with several hands is not a single --shape file.
  EXPECT_THROW(resolveHandShape(handShapesPath(kConfig), kConfig), InputError);

  const auto ok = parseHandShapes(
      "shapes:\n  - {name: a, scale: 0.9, finger_length: 1.1, phalanx_length: {index: [1, 1, 2]},"
      " skin: {dorsal: [0.1, 0.2, 0.3]}}\n",
      "t");
  ASSERT_EQ(ok.size(), 1u);
  EXPECT_EQ(ok[0].shape.finger_length[4], 1.1);
  EXPECT_EQ(ok[0].shape.phalanx_length[1][2], 2.0);
  EXPECT_EQ(ok[0].shape.phalanx_length[2][2], 1.0);
  EXPECT_EQ(ok[0].skin.dorsal, Eigen::Vector3f(0.1f, 0.2f, 0.3f));

  EXPECT_NE(expectInputError("shapes:\n  - {name: a, scael: 1}\n").find("test.yaml:2"),
            std::string::npos);
  EXPECT_NE(expectInputError("shapes:\n  - {name: a, scale: 15}\n").find("outside"),
            std::string::npos);
  EXPECT_NE(expectInputError("shapes:\n  - {name: a}\n  - {name: a}\n").find("twice"),
            std::string::npos);
  EXPECT_NE(expectInputError("shapes:\n  - {name: a b}\n").find("letters"), std::string::npos);
  EXPECT_NE(expectInputError("shapes:\n  - {name: a, skin: {dorsal: [1, 2, 0]}}\n").find("[0, 1]"),
            std::string::npos);
  EXPECT_NE(expectInputError("shapes:\n  - {name: a, finger_length: [1, 1]}\n").find("list of 5"),
            std::string::npos);
  EXPECT_NE(
      expectInputError("shapes:\n  - {name: a, phalanx_length: {toe: [1, 1, 1]}}\n").find("toe"),
      std::string::npos);
  EXPECT_NE(expectInputError("shapes: []\n").find("non-empty"), std::string::npos);
  EXPECT_NE(expectInputError("shapes:\n  - {scale: 1}\n").find("'name' is missing"),
            std::string::npos);
  expectInputError("shapes: [ {name: a\n");  // not YAML

  // Session 30: a FIFO as a shape file hung the tool in open(); a directory was an empty document.
  const std::string dir =
      (std::filesystem::temp_directory_path() / ("sag_shapes_" + std::to_string(::getpid())))
          .string();
  std::filesystem::create_directories(dir);
  ASSERT_EQ(::mkfifo((dir + "/fifo.yaml").c_str(), 0600), 0);
  EXPECT_EQ(sag_test::inputErrorOf([&] { resolveHandShape(dir + "/fifo.yaml", kConfig); }),
            "hand shapes " + dir + "/fifo.yaml: is not a regular file");
  EXPECT_EQ(sag_test::inputErrorOf([&] { loadHandShapes(dir); }),
            "hand shapes " + dir + ": is a directory, not a file");
  std::filesystem::remove_all(dir);
}

// Hands drawn at random (drawn<N>): the same name gives the same hand, other seeds other hands,
// every one within the config's envelope (size, fingers, phalanx proportions between the model's
// and a little past long_distal's, palm, thickness) and its skin between the config's tones.
TEST(StudioShapes, DrawnHandsAreReproducibleDistinctAndWithinTheEnvelope) {
  EXPECT_EQ(drawnHandSeed("drawn7"), 7);
  EXPECT_EQ(drawnHandSeed("drawn0"), 0);
  EXPECT_EQ(drawnHandSeed("drawn1000000"), kMaxDrawnHandSeed);
  for (const char* not_drawn : {"drawn", "drawn007", "drawn1000001", "drawn12345678", "drawn-1",
                                "drawn3a", "Drawn3", "xdrawn3", "default"}) {
    EXPECT_EQ(drawnHandSeed(not_drawn), -1) << not_drawn;
  }
  // The hold-out's hands are those of session 31 (doc/benchmark/session40/drawn9-16/results.md):
  // hands added to the config with tones already there (session 41) change none of them.
  EXPECT_EQ(resolveHandShape("drawn10", kConfig).description,
            "drawn with seed 10: size 1.10, phalanx proportions t 0.46, palm 0.96 wide and 1.05 "
            "long, thickness 0.93, skin dorsal [0.31, 0.19, 0.13]");
  const std::vector<SkinAlbedo> tones = configSkinTones(kConfig);
  EXPECT_EQ(tones.size(), 7u);  // the nine hands' seven distinct tones
  Eigen::Vector3f lightest = tones.front().dorsal, darkest = tones.front().dorsal;
  for (const SkinAlbedo& tone : tones) {
    lightest = lightest.cwiseMax(tone.dorsal);
    darkest = darkest.cwiseMin(tone.dorsal);
  }
  std::set<double> scales;
  double min_distal = 10.0, max_distal = 0.0;
  for (int seed = 0; seed < 200; ++seed) {
    SCOPED_TRACE(seed);
    const StudioHand hand = drawHandShape(seed, tones);
    EXPECT_EQ(hand.name, "drawn" + std::to_string(seed));
    const HandShape& s = hand.shape;
    scales.insert(s.scale);
    EXPECT_GE(s.scale, 0.9);
    EXPECT_LT(s.scale, 1.1);
    EXPECT_GE(s.scale * s.palm_width, 0.81);
    EXPECT_LE(s.scale * s.palm_width, 1.21);
    EXPECT_GE(s.thickness, 0.8);
    EXPECT_LT(s.thickness, 1.2);
    for (int f = 1; f < kNumFingers; ++f) {
      const double proximal = s.phalanx_length[f][0], distal = s.phalanx_length[f][2];
      EXPECT_GE(proximal, 0.8 * 0.95 - 1e-12);
      EXPECT_LE(proximal, 1.06 * 1.05 + 1e-12);
      EXPECT_GE(distal, 0.85 * 0.95 - 1e-12);
      EXPECT_LE(distal, 1.5 * 1.05 + 1e-12);
      min_distal = std::min(min_distal, distal);
      max_distal = std::max(max_distal, distal);
    }
    EXPECT_TRUE((hand.skin.dorsal.array() <= lightest.array() + 1e-6f).all());
    EXPECT_TRUE((hand.skin.dorsal.array() >= darkest.array() - 1e-6f).all());
    // The same seed, the same hand.
    const StudioHand again = drawHandShape(seed, tones);
    EXPECT_EQ(again.shape.phalanx_length, s.phalanx_length);
    EXPECT_EQ(again.shape.finger_length, s.finger_length);
    EXPECT_EQ(again.skin.dorsal, hand.skin.dorsal);
    EXPECT_EQ(again.description, hand.description);
  }
  EXPECT_EQ(scales.size(), 200u);  // other seeds, other hands
  EXPECT_LT(min_distal, 0.95);     // shorter distal phalanges than the model's, and
  EXPECT_GT(max_distal, 1.4);      // long_distal's
  // The figures of one hand, so that a change of the drawing shows (the hands of a run stay
  // comparable only if drawn<N> stays the same hand).
  const StudioHand seven = drawHandShape(7, tones);
  EXPECT_EQ(seven.description, resolveHandShape("drawn7", kConfig).description);
  EXPECT_EQ(seven.description.rfind("drawn with seed 7: size ", 0), 0u) << seven.description;
  // Without the config's tones, the default skin.
  EXPECT_EQ(drawHandShape(7, {}).skin.dorsal, SkinAlbedo().dorsal);
  EXPECT_THROW(drawHandShape(-1, tones), InputError);
  EXPECT_THROW(drawHandShape(kMaxDrawnHandSeed + 1, tones), InputError);
  // A config shape may not take a drawn hand's name.
  EXPECT_NE(expectInputError("shapes:\n  - {name: drawn5}\n").find("reserved"), std::string::npos);
  EXPECT_NO_THROW(parseHandShapes("shapes:\n  - {name: drawn05}\n", "t"));  // not a drawn name
}

// ---- bare forearm -----------------------------------------------------------------------------

TEST(StudioShapes, BareForearmIsSkinUpToTheElbowRegion) {
  const HandModel& model = handModel();
  const Pose pose = openHandPose();
  const PosedHand posed = forwardKinematics(model, pose);
  HandSurfaceParams sleeved, bare;
  bare.bare_forearm = true;
  auto forearmReach = [&](const HandSurfaceParams& params, std::uint8_t label) {
    double reach = 0.0;
    for (const SurfacePart& part : buildHandSurface(model, posed.bone_frames, params)) {
      if (part.label != label || part.kind != SurfacePart::Kind::kRoundCone) continue;
      reach = std::max(reach, (part.cone.b - pose.translation).norm());
    }
    return reach;
  };
  EXPECT_LT(forearmReach(sleeved, kLabelForearm), 0.05);  // only the bare wrist
  EXPECT_NEAR(forearmReach(bare, kLabelForearm), bare.bare_forearm_length, 1e-9);
  EXPECT_NEAR(forearmReach(bare, kLabelSleeve), bare.forearm_length, 1e-9);  // the elbow region

  // The rendered images: many more skin pixels with the bare forearm.
  const StudioRenderer renderer(dexter5());
  auto skinPixels = [&](const HandSurfaceParams& params) {
    const StudioImage image =
        renderer.renderCamera(0, {buildHandSurface(model, posed.bone_frames, params)}, 1);
    int n = 0;
    for (int i = 0; i < image.labels.rows * image.labels.cols; ++i) {
      n += image.labels.data[i] == kLabelForearm ? 1 : 0;
    }
    return n;
  };
  EXPECT_GT(skinPixels(bare), 3 * skinPixels(sleeved));

  // A motion asks for it (`forearm: {bare: true}`), and the sequence renders it.
  const Motion motion = loadMotion(resolveMotionPath("wristflex", kConfig), model, 1);
  ASSERT_TRUE(motion.bare_forearm.has_value());
  EXPECT_TRUE(*motion.bare_forearm);
  const StudioSequence sequence(model, motion, SequenceParams());
  EXPECT_TRUE(sequence.params().surface.bare_forearm);
  const StudioSequence dexter(model, loadMotion(resolveMotionPath("pinch", kConfig), model, 1),
                              SequenceParams());
  EXPECT_FALSE(dexter.params().surface.bare_forearm);
  EXPECT_THROW(parseMotion("forearm: {bare: maybe}\nkeyframes:\n  - {time: 0, position: [0, 0, "
                           "0.1]}\n  - {time: 1}\n",
                           "m.yaml", model, 1),
               InputError);
  EXPECT_THROW(parseMotion("forearm: {colour: red}\nkeyframes:\n  - {time: 0, position: [0, 0, "
                           "0.1]}\n  - {time: 1}\n",
                           "m.yaml", model, 1),
               InputError);
}

// ---- harder motions ---------------------------------------------------------------------------

TEST(StudioHardMotions, LoadStayInLimitsAboveTheTableAndInView) {
  const HandModel& model = handModel();
  ASSERT_EQ(hardMotionNames().size(), 5u);
  // On the default hand and the largest one.
  for (const std::string shape_name : {"default", "long_distal_large"}) {
    const StudioHand hand = resolveHandShape(shape_name, kConfig);
    for (const std::string& name : hardMotionNames()) {
      SCOPED_TRACE(name + " on " + shape_name);
      const Motion motion = loadMotion(resolveMotionPath(name, kConfig), model, 1);
      EXPECT_EQ(motion.name, name);
      SequenceParams params;
      params.shape = hand.shape;
      const StudioSequence sequence(model, motion, params);
      EXPECT_EQ(sequence.frameCount(), 300);
      for (int k = params.empty_frames; k < sequence.frameCount(); ++k) {
        const StudioFrame frame = sequence.frame(k);
        for (int j = 0; j < kNumJointDof; ++j) {
          ASSERT_GE(frame.pose.joints[j], model.joints[j].min) << "frame " << k;
          ASSERT_LE(frame.pose.joints[j], model.joints[j].max) << "frame " << k;
        }
        for (int f = 0; f < kNumFingers; ++f) {
          ASSERT_GT(frame.fingertips[f].z(), 0.01) << "frame " << k << ": fingertip in the table";
          int in_view = 0;
          for (const Camera& camera : dexter5()) {
            const Eigen::Vector3d p = camera.world_to_camera * frame.fingertips[f];
            const Eigen::Vector2d px = (camera.K * p).hnormalized();
            in_view += p.z() > 0 && px.x() >= 0 && px.y() >= 0 && px.x() < camera.width &&
                       px.y() < camera.height;
          }
          ASSERT_GE(in_view, 4) << "frame " << k << " " << fingerNames()[f];
        }
      }
    }
  }
}

TEST(StudioHardMotions, DoWhatTheirNamesSay) {
  const HandModel& model = handModel();
  struct Extremes {
    double min_back_z = 1.0;          // back-of-hand normal's z: -1 palm up
    double max_finger_z = -1.0;       // palm x axis' z: 1 fingers straight up
    double max_turn_rate = 0.0;       // deg/s between frames at 25 fps
    double max_forward_change = 0.0;  // the hand axis' largest turn from its start (deg)
    double min_camera_angle = 180.0;  // the index's direction to a camera's line of sight (deg)
    double max_away_angle = 0.0;  // the same to the nearest camera: > 90, away from every camera
  };
  const Eigen::Vector3d forward = middleKnuckleDirection(model);
  auto measure = [&](const std::string& name) {
    const Motion motion = loadMotion(resolveMotionPath(name, kConfig), model, 1);
    const StudioSequence sequence(model, motion, SequenceParams());
    const auto chains = fingerChains(sequence.shapedModel());
    Extremes e;
    Eigen::Matrix3d previous = sequence.frame(10).pose.rotation;
    const Eigen::Vector3d start = previous * forward;
    for (int k = 10; k < sequence.frameCount(); ++k) {
      const Pose pose = sequence.frame(k).pose;
      e.min_back_z = std::min(e.min_back_z, pose.rotation(2, 2));
      e.max_finger_z = std::max(e.max_finger_z, pose.rotation(2, 0));
      const Eigen::AngleAxisd step(previous.transpose() * pose.rotation);
      e.max_turn_rate = std::max(e.max_turn_rate, step.angle() * 180.0 / M_PI * 25.0);
      e.max_forward_change =
          std::max(e.max_forward_change, angleBetweenDeg(start, pose.rotation * forward));
      previous = pose.rotation;
      // The index finger's middle bone direction against each camera's line of sight to it.
      const PosedHand posed = forwardKinematics(sequence.shapedModel(), pose);
      const Eigen::Isometry3d& bone = posed.bone_frames[chains[1][1]];
      double nearest = 180.0;
      for (const Camera& camera : dexter5()) {
        const Eigen::Vector3d centre = camera.world_to_camera.inverse().translation();
        nearest =
            std::min(nearest, angleBetweenDeg(bone.linear().col(0), centre - bone.translation()));
      }
      e.min_camera_angle = std::min(e.min_camera_angle, nearest);
      e.max_away_angle = std::max(e.max_away_angle, nearest);
    }
    return e;
  };
  const Extremes raised = measure("raised");
  EXPECT_GT(raised.max_finger_z, 0.95);      // vertical, fingers up
  EXPECT_LT(raised.min_camera_angle, 20.0);  // the index pointing right at a camera
  EXPECT_GT(raised.max_away_angle, 100.0);   // and away from every camera
  EXPECT_GT(raised.max_forward_change, 120.0);
  const Extremes pronation = measure("pronation");
  EXPECT_LT(pronation.min_back_z, -0.95);  // palm up: turned through 180 deg
  const Extremes wristflex = measure("wristflex");
  EXPECT_GT(wristflex.max_finger_z, 0.6);  // extension (fingers up) ...
  EXPECT_LT(wristflex.min_back_z, -0.9);   // ... and palm up as well
  const Extremes fastturn = measure("fastturn");
  EXPECT_GT(fastturn.max_turn_rate, 400.0);  // fast: more than 16 deg between frames
  EXPECT_LT(fastturn.min_back_z, -0.9);
  EXPECT_GT(fastturn.max_forward_change, 150.0);
  // `natural`: the fingers' joints move independently, as a person's do (hook: PIP bent with the
  // MCP straight; flat: the reverse), unlike the open-to-fist keyframes of the other motions, where
  // the MCP is 0.85 x the PIP within 0.06 rad (rms; doc/history.md "Session 21").
  auto joint = [&](const std::string& name) {
    const int j = model.jointIndex(name);
    if (j >= 0) return j;
    ADD_FAILURE() << "no joint " << name;
    return 0;
  };
  auto couplingRms = [&](const std::string& name) {
    const Motion motion = loadMotion(resolveMotionPath(name, kConfig), model, 1);
    const StudioSequence sequence(model, motion, SequenceParams());
    double sum = 0.0;
    int count = 0;
    for (int k = 10; k < sequence.frameCount(); ++k) {
      const Pose pose = sequence.frame(k).pose;
      for (const std::string finger : {"index", "middle", "ring", "pinky"}) {
        const double mcp = pose.joints[joint(finger + "_mcp_flex")];
        const double pip = pose.joints[joint(finger + "_pip_flex")];
        sum += (mcp - 0.85 * pip) * (mcp - 0.85 * pip);
        ++count;
      }
    }
    return std::sqrt(sum / count);
  };
  EXPECT_GT(couplingRms("natural"), 0.4);
  EXPECT_LT(couplingRms("fingercount"), 0.1);
  const Extremes natural = measure("natural");
  EXPECT_GT(natural.max_forward_change, 45.0);  // lifted and turning, not palm down
  // None turns faster than a human forearm and wrist can (about 1000 deg/s at most).
  for (const Extremes& e : {raised, pronation, wristflex, fastturn, natural}) {
    EXPECT_LT(e.max_turn_rate, 1000.0);
  }
}
