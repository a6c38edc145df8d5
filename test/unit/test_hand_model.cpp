#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <regex>

#include "sag_hand_tracker/model/kinematics.h"
#include "test_support/synthetic_scene.h"
#include "test_support/temp_files.h"

using namespace sag_hand_tracker;
using namespace sag_test;

namespace {

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Writes `text` to a temporary model file and returns the loader's error message.
std::string loadError(const std::string& text) {
  const std::string path = testing::TempDir() + "/model_under_test.yaml";
  std::ofstream(path) << text;
  try {
    loadHandModel(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(HandModel, LoadsTheBuiltInModels) {
  const HandModel sag = loadHandModel(modelPath("sag"));
  EXPECT_EQ(sag.gaussians.size(), 17u);
  EXPECT_EQ(sag.joints.size(), static_cast<size_t>(kNumJointDof));
  EXPECT_EQ(sag.bones.size(), 16u);
  EXPECT_EQ(sag.projection, ProjectionMode::kPerspective);
  EXPECT_EQ(sag.parameterNames().size(), static_cast<size_t>(kNumDof));
  EXPECT_EQ(sag.parameterNames()[6], "thumb_cmc_flex");
  const HandModel sog = loadHandModel(modelPath("sog"));
  EXPECT_EQ(sog.gaussians.size(), 30u);
  EXPECT_EQ(sog.projection, ProjectionMode::kScaledOrthographic);
  for (const ModelGaussian& g : sog.gaussians) {
    EXPECT_NEAR(g.cov(0, 0), g.cov(1, 1), 1e-15);  // isotropic
    EXPECT_NEAR(g.cov(0, 0), g.cov(2, 2), 1e-15);
  }
}

// The fingertip (doc/design.md section 4) is the end of the distal bone in both models.
// longFingerJoints: index to pinky, each joint the one of that name; -1 for a joint a model lacks.
TEST(HandModel, LongFingerJointsAreTheNamedJoints) {
  HandModel model = loadHandModel(modelPath("sag"));
  const auto joints = longFingerJoints(model);
  for (int f = 1; f < kNumFingers; ++f) {
    const std::string finger = fingerNames()[f];
    const LongFingerJoints& j = joints[f - 1];
    EXPECT_EQ(j.mcp_flex, model.jointIndex(finger + "_mcp_flex")) << finger;
    EXPECT_EQ(j.mcp_abd, model.jointIndex(finger + "_mcp_abd")) << finger;
    EXPECT_EQ(j.pip_flex, model.jointIndex(finger + "_pip_flex")) << finger;
    EXPECT_EQ(j.dip_flex, model.jointIndex(finger + "_dip_flex")) << finger;
    EXPECT_GE(j.mcp_flex, 0) << finger;
    EXPECT_GE(j.dip_flex, 0) << finger;
  }
  model.joints[model.jointIndex("ring_dip_flex")].name = "ring_distal";
  EXPECT_EQ(longFingerJoints(model)[2].dip_flex, -1);
}

TEST(HandModel, FingertipsAreTheDistalBoneEnds) {
  for (const std::string name : {"sag", "sog"}) {
    const HandModel model = loadHandModel(modelPath(name));
    const Pose pose = typicalPose(model);
    const PosedHand hand = forwardKinematics(model, pose);
    const auto tips = fingertips(model, hand);
    for (int f = 0; f < kNumFingers; ++f) {
      const int bone = model.gaussians[model.fingertip_gaussians[f]].bone;
      const Eigen::Vector3d bone_end =
          hand.bone_frames[bone] * Eigen::Vector3d(model.bones[bone].length, 0, 0);
      EXPECT_LT((tips[f] - bone_end).norm(), 1e-9) << name << " finger " << f;
    }
  }
}

TEST(HandModel, FlexionBendsTowardThePalm) {
  const HandModel model = loadHandModel(modelPath("sag"));
  Pose pose = neutralPose(model, Eigen::Vector3d::Zero(), Eigen::Matrix3d::Identity());
  const double open_z = fingertips(model, pose)[1].z();
  pose.joints[4] = 1.0;                                      // index MCP flexion
  EXPECT_LT(fingertips(model, pose)[1].z(), open_z - 0.02);  // palm side is -z
  // Right hand, palm down, fingers along +x: the thumb is on +y.
  EXPECT_GT(fingertips(model, pose)[0].y(), fingertips(model, pose)[4].y());
}

TEST(HandModel, LeftHandIsTheMirrorImage) {
  const HandModel right = loadHandModel(modelPath("sag"));
  const HandModel left = loadHandModel(modelPath("sag"), Handedness::kLeft);
  EXPECT_EQ(left.handedness, Handedness::kLeft);
  Pose pose = typicalPose(right);
  pose.translation.setZero();
  pose.rotation.setIdentity();
  const auto right_tips = fingertips(right, pose);
  const auto left_tips = fingertips(left, pose);
  for (int f = 0; f < kNumFingers; ++f) {
    EXPECT_NEAR(left_tips[f].x(), right_tips[f].x(), 1e-12);
    EXPECT_NEAR(left_tips[f].y(), -right_tips[f].y(), 1e-12);
    EXPECT_NEAR(left_tips[f].z(), right_tips[f].z(), 1e-12);
  }
}

// scaleHandModel (the tracker's size adaptation): (f, f) is the whole hand f times as large about
// the wrist at any pose; (f, 1) stretches the lengths and keeps every finger's and the palm's
// thickness.
TEST(HandModel, ScalingStretchesAboutTheWristAndKeepsTheThicknessAsked) {
  const HandModel model = loadHandModel(modelPath("sag"));
  Pose pose = typicalPose(model);
  const auto tips = fingertips(model, pose);
  const HandModel larger = scaleHandModel(model, 1.1, 1.1);
  const auto larger_tips = fingertips(larger, pose);
  for (int f = 0; f < kNumFingers; ++f) {
    EXPECT_LT((larger_tips[f] - pose.translation - 1.1 * (tips[f] - pose.translation)).norm(),
              1e-12);
  }
  const PosedHand posed = forwardKinematics(model, pose);
  const PosedHand posed_larger = forwardKinematics(larger, pose);
  for (size_t g = 0; g < model.gaussians.size(); ++g) {
    EXPECT_TRUE(posed_larger.gaussians[g].cov.isApprox(1.21 * posed.gaussians[g].cov, 1e-12));
  }

  const HandModel stretched = scaleHandModel(model, 0.9, 1.0);
  const auto stretched_tips = fingertips(stretched, pose);
  for (int f = 0; f < kNumFingers; ++f) {
    EXPECT_LT((stretched_tips[f] - pose.translation - 0.9 * (tips[f] - pose.translation)).norm(),
              1e-12);
  }
  for (size_t g = 0; g < model.gaussians.size(); ++g) {
    const Eigen::Matrix3d& before = model.gaussians[g].cov;
    const Eigen::Matrix3d& after = stretched.gaussians[g].cov;
    EXPECT_NEAR(after(0, 0), 0.81 * before(0, 0), 1e-15);  // along the bone (the palm's length)
    EXPECT_NEAR(after(2, 2), before(2, 2), 1e-15);         // the thickness
    EXPECT_NEAR(after(1, 1), (g < 2 ? 0.81 : 1.0) * before(1, 1), 1e-15)  // the palm's width
        << "Gaussian " << g << " on bone " << model.gaussians[g].bone;
    EXPECT_EQ(stretched.gaussians[g].hsv, model.gaussians[g].hsv);
  }
  ASSERT_EQ(model.gaussians[0].bone, 0);
  ASSERT_EQ(model.gaussians[1].bone, 0);
  ASSERT_NE(model.gaussians[2].bone, 0);
  for (size_t j = 0; j < model.joints.size(); ++j) {
    EXPECT_EQ(stretched.joints[j].axis, model.joints[j].axis);
    EXPECT_EQ(stretched.joints[j].min, model.joints[j].min);
  }
  EXPECT_THROW(scaleHandModel(model, 0.0, 1.0), InputError);
  EXPECT_THROW(scaleHandModel(model, 1.0, std::nan("")), InputError);
}

TEST(HandModel, MissingFileIsNamed) {
  try {
    loadHandModel("/nonexistent/hand.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/hand.yaml"), std::string::npos);
  }
}

TEST(HandModel, MalformedYamlNamesTheLine) {
  const std::string message = loadError("name: x\nhandedness: right\nbones: [\n  - {name: palm\n");
  EXPECT_NE(message.find("malformed YAML"), std::string::npos) << message;
  EXPECT_TRUE(std::regex_search(message, std::regex("model_under_test.yaml:[0-9]+: "))) << message;
}

TEST(HandModel, MissingKeyNamesKeyAndLine) {
  std::string text = readFile(modelPath("sag"));
  text = std::regex_replace(text, std::regex("projection: perspective\n"), "");
  const std::string message = loadError(text);
  EXPECT_NE(message.find("key 'projection': missing"), std::string::npos) << message;
  // A missing key is reported at its map (the top level starts after the comments).
  EXPECT_TRUE(std::regex_search(message, std::regex("model_under_test.yaml:[0-9]+: key")))
      << message;
}

TEST(HandModel, UnknownColoursValueIsNamed) {
  std::string text = readFile(modelPath("sag"));
  text = std::regex_replace(text, std::regex("projection: perspective\n"),
                            "projection: perspective\ncolours: learnt\n");
  const std::string message = loadError(text);
  EXPECT_NE(message.find("'colours'"), std::string::npos) << message;
  EXPECT_NE(message.find("must be 'model' or 'fitted', not 'learnt'"), std::string::npos)
      << message;
}

TEST(HandModel, NonPositiveDefiniteCovarianceIsRejected) {
  std::string text = readFile(modelPath("sag"));
  text = std::regex_replace(text, std::regex("sigma: \\[0.030, 0.030, 0.014\\]"),
                            "sigma: [0.030, 0.0, 0.014]");
  const std::string message = loadError(text);
  EXPECT_NE(message.find("not positive definite"), std::string::npos) << message;
  EXPECT_TRUE(
      std::regex_search(message, std::regex(":1[0-9][0-9]: key 'gaussians\\[[0-9]+\\]\\.sigma'")))
      << message;  // lines 1xx
}

TEST(HandModel, WrongNumberOfDofIsRejected) {
  std::string text = readFile(modelPath("sag"));
  text = std::regex_replace(text, std::regex("      - \\{name: thumb_cmc_abd[^\n]*\n"), "");
  const std::string message = loadError(text);
  EXPECT_NE(message.find("wrong number of DOF"), std::string::npos) << message;
  EXPECT_NE(message.find("25"), std::string::npos) << message;
}

TEST(HandModel, UnknownBoneAndBadAxisAreNamed) {
  std::string text = readFile(modelPath("sag"));
  std::string message =
      loadError(std::regex_replace(text, std::regex("bone: ring_middle"), "bone: ring_midle"));
  EXPECT_NE(message.find("unknown bone 'ring_midle'"), std::string::npos) << message;
  message = loadError(std::regex_replace(text, std::regex("axis: z"), "axis: w"));
  EXPECT_TRUE(std::regex_search(
      message, std::regex("key 'bones\\[[0-9]+\\]\\.dofs\\[[0-9]+\\]\\.axis': must be x, y or z")))
      << message;
}

TEST(Camera, ValidationNamesTheProblem) {
  Camera camera = fiveCameraRig()[1];
  EXPECT_NO_THROW(validateCamera(camera));
  camera.K(1, 1) = -5.0;
  EXPECT_THROW(validateCamera(camera), InputError);
  camera = fiveCameraRig()[1];
  camera.width = 0;
  EXPECT_THROW(validateCamera(camera), InputError);
  camera = fiveCameraRig()[1];
  camera.world_to_camera.linear() *= 2.0;
  EXPECT_THROW(validateCamera(camera), InputError);
}

// The principal point lies within [-w, 2w] x [-h, 2h] and |skew| <= fx (hostile camera_info and
// calibration files: cx -5000, cx 1e300, skew 1e6 were accepted).
TEST(Camera, PrincipalPointAndSkewAreRangeChecked) {
  const Camera good = fiveCameraRig()[1];
  Camera camera = good;
  camera.K(0, 2) = -5000.0;
  std::string message = sag_test::inputErrorOf([&] { validateCamera(camera); });
  EXPECT_NE(message.find("camera '" + good.name + "': principal point (cx -5000,"),
            std::string::npos)
      << message;
  camera = good;
  camera.K(0, 2) = 1e300;
  EXPECT_THROW(validateCamera(camera), InputError);
  camera = good;
  camera.K(1, 2) = 2.0 * camera.height + 1.0;
  EXPECT_THROW(validateCamera(camera), InputError);
  camera = good;
  camera.K(1, 2) = -camera.height;  // the edge of the range is still a camera
  EXPECT_NO_THROW(validateCamera(camera));
  camera = good;
  camera.K(0, 1) = 1e6;
  message = sag_test::inputErrorOf([&] { validateCamera(camera); });
  EXPECT_NE(message.find("skew K(0,1) = 1e+06 exceeds the focal length"), std::string::npos)
      << message;
  camera.K(0, 1) = 0.5;  // a small skew is a lens
  EXPECT_NO_THROW(validateCamera(camera));
}

TEST(Camera, UndistortionMovesImageGaussians) {
  Camera camera = fiveCameraRig()[0];
  ImageSoG sog;
  sog.gaussians.push_back({Eigen::Vector2d(300.0, 220.0), 2.0, Hsv::Zero()});
  ImageSoG unchanged = sog;
  undistortImageSoG(camera, &unchanged);
  EXPECT_EQ(unchanged.gaussians[0].mean, sog.gaussians[0].mean);
  camera.distortion = {-0.2, 0.05, 0.0, 0.0, 0.0};
  ImageSoG with_sleeve = sog;  // the forearm evidence moves with it
  with_sleeve.arm_cells = 1;
  with_sleeve.arm_centroid = Eigen::Vector2d(300.0, 220.0);
  with_sleeve.arm_gaussians = sog.gaussians;
  undistortImageSoG(camera, &sog);
  // Barrel distortion pulls points in: undistorting pushes a corner point outward.
  EXPECT_GT(sog.gaussians[0].mean.x(), 300.0);
  undistortImageSoG(camera, &with_sleeve);
  ASSERT_EQ(with_sleeve.arm_gaussians.size(), 1u);
  EXPECT_EQ(with_sleeve.arm_gaussians[0].mean, sog.gaussians[0].mean);
  EXPECT_EQ(with_sleeve.arm_centroid, sog.gaussians[0].mean);
}
