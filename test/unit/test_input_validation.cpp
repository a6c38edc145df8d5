// The validation policy where data enters the core (input_limits.h, yaml_reader.h): the hostile
// inputs of issue 12 are refused with an error naming the file, line and key, before anything
// large is allocated.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/studio/hand_shapes.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/util/input_limits.h"
#include "sag_hand_tracker/util/yaml_reader.h"
#include "test_support/synthetic_scene.h"
#include "test_support/temp_files.h"

using namespace sag_hand_tracker;

namespace {

std::string builtinModelText() {
  std::ifstream in(sag_test::modelPath("sag"));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The message of parsing the built-in SAG model with `from` replaced by `to` (first match).
std::string modelError(const std::string& from, const std::string& to) {
  const std::string text = std::regex_replace(builtinModelText(), std::regex(from), to,
                                              std::regex_constants::format_first_only);
  EXPECT_NE(text, builtinModelText()) << "pattern not found: " << from;
  return sag_test::inputErrorOf([&] { parseHandModel(text, "hand.yaml"); });
}

const char* kCalibration = R"(image_width: 320
image_height: 240
camera_matrix: {rows: 3, cols: 3, data: [300, 0, 160, 0, 300, 120, 0, 0, 1]}
distortion_model: plumb_bob
distortion_coefficients: {rows: 1, cols: 5, data: [0, 0, 0, 0, 0]}
)";

std::string calibrationError(const std::string& from, const std::string& to) {
  const std::string text = std::regex_replace(std::string(kCalibration), std::regex(from), to);
  return sag_test::inputErrorOf([&] { parseCameraCalibration(text, "cam.yaml"); });
}

std::string rigError(const std::string& text) {
  return sag_test::inputErrorOf([&] {
    parseCameraRig(text, "rig.yaml",
                   [](const std::string&) { return parseCameraCalibration(kCalibration, "c"); });
  });
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

}  // namespace

TEST(InputValidation, ModelBoneLengthMustBeFiniteAndNotNegative) {
  std::string message = modelError("length: 0.045", "length: .nan");
  EXPECT_TRUE(contains(message, "hand model hand.yaml:")) << message;
  EXPECT_TRUE(contains(message, "key 'bones[1].length': must be finite")) << message;
  message = modelError("length: 0.045", "length: -0.045");
  EXPECT_TRUE(contains(message, "key 'bones[1].length': -0.045 is outside [0, 1]")) << message;
}

TEST(InputValidation, ModelBoneOffsetIsLimitedToAMetre) {
  std::string message =
      modelError("offset: \\[0.022, 0.022, -0.008\\]", "offset: [5, 0.022, -0.008]");
  EXPECT_TRUE(contains(message, "hand model hand.yaml:")) << message;
  EXPECT_TRUE(contains(message, "key 'bones[1].offset': is more than 1")) << message;
  message = modelError("offset: \\[0.022, 0.022, -0.008\\]", "offset: [1e308, 1e308, 0]");
  EXPECT_TRUE(contains(message, "key 'bones[1].offset': is more than 1")) << message;
}

// Session 30 found them only required to be finite (1e308 deg was read).
TEST(InputValidation, ModelAnglesAreWithinOneTurn) {
  std::string message = modelError("rest_rpy_deg: \\[([-0-9.]+),", "rest_rpy_deg: [1e308,");
  EXPECT_TRUE(std::regex_search(
      message, std::regex("key 'bones\\[[0-9]+\\]\\.rest_rpy_deg': angles must be within "
                          "\\[-360, 360\\] degrees")))
      << message;
  message = modelError("sigma: \\[([0-9.]+), ([0-9.]+), ([0-9.]+)\\]",
                       "sigma: [$1, $2, $3], rpy_deg: [0, -361, 0]");
  EXPECT_TRUE(contains(message, "key 'gaussians[0].rpy_deg': angles must be within [-360, 360]"))
      << message;
  const std::string turned = std::regex_replace(
      builtinModelText(), std::regex("sigma: \\[([0-9.]+), ([0-9.]+), ([0-9.]+)\\]"),
      "sigma: [$1, $2, $3], rpy_deg: [0, -360, 10]", std::regex_constants::format_first_only);
  EXPECT_NO_THROW(parseHandModel(turned, "hand.yaml"));
}

// Session 34: a frame_id "cam1\n\x1b[31mred\0x" in an error printed a live terminal escape, and
// the message ended at the NUL.
TEST(InputValidation, ErrorsWriteControlCharactersAsEscapes) {
  const std::string frame("cam1\n\x1b[31mred\0x", 15);
  const InputError error("frame '" + frame + "' is not in /tf_static");
  EXPECT_EQ(std::string(error.what()), "frame 'cam1\n\\x1b[31mred\\x00x' is not in /tf_static");
  EXPECT_EQ(std::string(InputError("Håndmodell ✋ café").what()), "Håndmodell ✋ café");
}

// Session 34: misspelt top-level keys of a model or a rig were ignored without a word.
TEST(InputValidation, ModelAndRigTopLevelKeysAreKnownOnes) {
  std::string message =
      modelError("projection: perspective", "projection: perspective\ncolors: fitted");
  EXPECT_TRUE(contains(message, "key 'colors': unknown key (expected one of: name, handedness"))
      << message;
  message = rigError(R"(root_frame: world
root_frme: x
cameras:
  - {name: cam0, calibration: c.yaml, translation: [0, 0, 0], rotation: [0, 0, 0, 1]}
)");
  EXPECT_TRUE(contains(message,
                       "rig.yaml:2: key 'root_frme': unknown key (expected one of: "
                       "root_frame, cameras)"))
      << message;
}

TEST(InputValidation, ModelNameIsPrintableText) {
  const std::string message = modelError("name: ([a-z_]+)", "name: \"sag\\x07right\"");
  EXPECT_TRUE(contains(message, "key 'name': must be printable text (no control characters)"))
      << message;
}

TEST(InputValidation, ModelBoneWithoutOffsetIsRefused) {
  const std::string message = modelError("    offset: \\[0.022, 0.022, -0.008\\]\n", "");
  EXPECT_TRUE(contains(message, "key 'bones[1].offset': missing")) << message;
}

TEST(InputValidation, ModelDuplicateDofNameIsRefused) {
  const std::string message = modelError("name: thumb_cmc_abd", "name: thumb_cmc_flex");
  EXPECT_TRUE(contains(message, "key 'bones[1].dofs[1].name': DOF 'thumb_cmc_flex' defined twice"))
      << message;
}

TEST(InputValidation, ModelHsvOutOfRangeIsRefused) {
  std::string message =
      modelError("hsv: \\[([0-9.]+), ([0-9.]+), ([0-9.]+)\\]", "hsv: [$1, 1.5, $3]");
  EXPECT_TRUE(std::regex_search(message, std::regex("key 'gaussians\\[0\\]\\.hsv': must be")))
      << message;
  message = modelError("hsv: \\[([0-9.]+),", "hsv: [400,");
  EXPECT_TRUE(contains(message, "h in [0, 360]")) << message;
}

TEST(InputValidation, ModelNamesMustBeSafeFrameNames) {
  const std::string message = modelError("name: thumb_metacarpal", "name: ../../etc");
  EXPECT_TRUE(contains(message, "not a safe frame name")) << message;
}

// Session 30: two fingers on one fingertip bone were tracked and fitted as one finger twice (the
// same fingertip in two CSV columns); the palm as a fingertip failed only in the studio and the
// fit.
TEST(InputValidation, ModelFingertipsAreDistinctFingerBones) {
  std::string message = modelError("thumb: thumb_distal", "thumb: index_distal");
  EXPECT_TRUE(contains(message,
                       "key 'fingertips.index': bone 'index_distal' is already the thumb's "
                       "fingertip; each finger needs its own"))
      << message;
  message = modelError("ring: ring_distal", "ring: palm");
  EXPECT_TRUE(contains(
      message, "key 'fingertips.ring': is the palm (the root bone), not a finger's last bone"))
      << message;
  HandModel model = loadHandModel(sag_test::modelPath("sag"));
  model.fingertip_gaussians[2] = model.fingertip_gaussians[1];
  EXPECT_EQ(sag_test::inputErrorOf([&] { validateHandModel(model); }),
            "the index and the middle have one fingertip Gaussian");
}

TEST(InputValidation, ModelGaussianCountIsLimitedBeforeParsingThem) {
  std::string text = builtinModelText();
  const std::size_t at = text.find("gaussians:\n") + std::string("gaussians:\n").size();
  std::string many;
  for (int i = 0; i <= kMaxModelGaussians; ++i) {
    many += "  - {bone: palm, mean: [0, 0, 0], sigma: [0.01, 0.01, 0.01], hsv: [20, 0.4, 0.8]}\n";
  }
  text.insert(at, many);
  ASSERT_LT(text.size(), kMaxYamlFileBytes);
  const std::string message = sag_test::inputErrorOf([&] { parseHandModel(text, "hand.yaml"); });
  // 17 + 65: the limit is 64 (a model of 1000 Gaussians made calibrate_hand run for hours). The
  // line is the list's, its first entry's.
  const long line = 1 + std::count(text.begin(), text.begin() + at, '\n');
  EXPECT_EQ(message,
            "hand model hand.yaml:" + std::to_string(line) +
                ": key 'gaussians': has 82 Gaussians, more than the limit of 64 for a hand model "
                "(the SAG model has 17, the SoG model 30)");
}

// A Gaussian sigma of 1e-300 passed the parser and made validateHandModel find the covariance
// singular, with neither key nor line; the parser bounds it (kMinModelSigmaMetres) itself.
TEST(InputValidation, ModelTinySigmaIsRefusedWithItsKeyAndLine) {
  std::string message =
      modelError("sigma: \\[0.030, 0.030, 0.014\\]", "sigma: [0.030, 1e-300, 0.014]");
  EXPECT_TRUE(contains(message,
                       "hand model hand.yaml:129: key 'gaussians[0].sigma': standard deviation "
                       "1e-300 m is below the limit of 0.0001 m (0.1 mm)"))
      << message;
  message = modelError("sigma: \\[0.030, 0.030, 0.014\\]", "sigma: [0.030, 0.030, 9e-5]");
  EXPECT_TRUE(contains(message, "key 'gaussians[0].sigma': standard deviation 9e-05 m is below"))
      << message;
  // At the limit it loads.
  const std::string text =
      std::regex_replace(builtinModelText(), std::regex("sigma: \\[0.030, 0.030, 0.014\\]"),
                         "sigma: [0.030, 0.030, 1e-4]");
  EXPECT_NO_THROW(parseHandModel(text, "hand.yaml"));
}

// The DOF count was left to validateHandModel (the file, no key or line); the parser names it.
TEST(InputValidation, ModelWrongDofCountNamesTheBonesKey) {
  const std::string message = modelError("      - \\{name: thumb_cmc_abd[^\n]*\n", "");
  EXPECT_TRUE(contains(message,
                       "hand model hand.yaml:11: key 'bones': wrong number of DOF: the model has "
                       "25, the tracker needs 26"))
      << message;
}

// A key twice in one map was accepted silently (yaml-cpp keeps both entries, its look-ups take
// the first): the one YAML parse refuses it for every kind of input, at the second occurrence,
// with the first's line and the map's key path.
TEST(InputValidation, DuplicateYamlKeysAreRefusedInEveryInput) {
  std::string message = modelError("    length: 0.045\n", "    length: 0.045\n    length: 0.05\n");
  EXPECT_TRUE(contains(message,
                       "hand model hand.yaml:21: key 'bones[1]': duplicate key 'length' (first at "
                       "line 20)"))
      << message;
  message = modelError("axis: y, min_deg: -20", "axis: y, \"axis\": z, min_deg: -20");
  EXPECT_TRUE(contains(message,
                       "hand model hand.yaml:22: key 'bones[1].dofs[0]': duplicate key 'axis' "
                       "(first at line 22)"))
      << message;
  message = modelError("projection: perspective\n", "projection: perspective\nname: other\n");
  EXPECT_TRUE(contains(message, "hand model hand.yaml:10: duplicate key 'name' (first at line 7)"))
      << message;

  message = calibrationError("image_height: 240\n", "image_height: 240\nimage_width: 640\n");
  EXPECT_EQ(message, "calibration file cam.yaml:3: duplicate key 'image_width' (first at line 1)");
  message = rigError(R"(root_frame: world
cameras:
  - {name: cam0, calibration: c.yaml, translation: [0, 0, 0], rotation: [0, 0, 0, 1],
     translation: [1, 0, 0]}
)");
  EXPECT_EQ(message,
            "rig file rig.yaml:4: key 'cameras[0]': duplicate key 'translation' (first at line 3)");
  const HandModel model = loadHandModel(sag_test::modelPath("sag"));
  message = sag_test::inputErrorOf([&] {
    studio::parseMotion(
        "keyframes:\n  - {time: 0, position: [0, 0, 0.15]}\nduration: 3\n"
        "duration: 4\n",
        "m.yaml", model, 1);
  });
  EXPECT_EQ(message, "motion m.yaml:4: duplicate key 'duration' (first at line 3)");
  message = sag_test::inputErrorOf([] {
    studio::parseHandShapes("shapes:\n  - name: big\n    scale: 1.1\n    scale: 1.2\n",
                            "shapes.yaml");
  });
  EXPECT_EQ(message,
            "hand shapes shapes.yaml:4: key 'shapes[0]': duplicate key 'scale' (first at line 3)");
  // The same key in different maps is no duplicate.
  EXPECT_NO_THROW(parseYamlText("a: {x: 1}\nb: {x: 2}\nc: [{x: 1}, {x: 2}]\n", "t.yaml", "test"));
}

// 10000 '[' gave "malformed YAML: bad file" (yaml-cpp's own depth guard); nesting deeper than
// kMaxYamlNestingDepth is named, with the line and the key path, and refused as soon as it is
// reached, so 100000 levels cost no deep recursion either.
TEST(InputValidation, DeeplyNestedYamlIsRefusedAsTooDeep) {
  const std::string limit = "': maps and lists nested deeper than the limit of 64 levels$";
  // Closed lists: the 64th is the 65th level (the document's map is the first).
  const std::regex too_deep("^hand model deep.yaml:2: key 'bones(\\[0\\]){63}" + limit);
  // Unclosed ones, as the probe sent them: yaml-cpp reads each '[' after the first as a list and
  // the key of a map within it, two levels.
  const std::regex too_deep_unclosed("^hand model deep.yaml:2: key 'bones(\\[0\\]){32}" + limit);
  for (const int levels : {64, 10000, 100000}) {
    std::string message = sag_test::inputErrorOf([&] {
      parseHandModel(
          "name: x\nbones: " + std::string(levels, '[') + std::string(levels, ']') + "\n",
          "deep.yaml");
    });
    EXPECT_TRUE(std::regex_match(message, too_deep)) << levels << ": " << message;
    message = sag_test::inputErrorOf(
        [&] { parseHandModel("name: x\nbones: " + std::string(levels, '[') + "\n", "deep.yaml"); });
    EXPECT_TRUE(std::regex_match(message, too_deep_unclosed)) << levels << ": " << message;
  }
  // Block lists and flow maps count alike, in every reader.
  std::string block = "a:\n  ";
  for (int level = 0; level < 100; ++level) block += "- ";
  std::string message =
      sag_test::inputErrorOf([&] { parseCameraCalibration(block + "x\n", "cam.yaml"); });
  EXPECT_TRUE(contains(message, "calibration file cam.yaml:2: key 'a[0][0]")) << message;
  EXPECT_TRUE(contains(message, "nested deeper than the limit of 64 levels")) << message;
  std::string maps;
  for (int level = 0; level < 200; ++level) maps += "{k: ";
  message = rigError("root_frame: world\ncameras: " + maps + "1" + std::string(200, '}') + "\n");
  EXPECT_TRUE(contains(message, "rig file rig.yaml:2: key 'cameras.k.k.k")) << message;
  EXPECT_TRUE(contains(message, "nested deeper than the limit of 64 levels")) << message;
  // 64 levels (the document's map and 63 lists) are within the limit.
  message = sag_test::inputErrorOf([] {
    parseHandModel("name: x\nbones: " + std::string(63, '[') + std::string(63, ']') + "\n",
                   "deep.yaml");
  });
  EXPECT_FALSE(contains(message, "nested deeper")) << message;
}

class InputFiles : public sag_test::TempDirTest {};

// The file loader names the file (and the line and key) for a value the parser bounds.
TEST_F(InputFiles, ATinySigmaInAModelFileNamesTheFileLineAndKey) {
  const std::string path = this->path("tiny_sigma.yaml");
  {
    std::ofstream out(path);
    out << std::regex_replace(builtinModelText(), std::regex("sigma: \\[0.030, 0.030, 0.014\\]"),
                              "sigma: [0.030, 0.030, 1e-300]");
  }
  const std::string message = sag_test::inputErrorOf([&] { loadHandModel(path); });
  EXPECT_EQ(message.rfind("hand model " + path + ":129: key 'gaussians[0].sigma': ", 0), 0u)
      << message;
}

TEST_F(InputFiles, ADirectoryAsModelIsNamed) {
  const std::string message = sag_test::inputErrorOf([&] { loadHandModel(dir_.string()); });
  EXPECT_EQ(message, "hand model " + dir_.string() + ": is a directory, not a file");
}

TEST_F(InputFiles, AnOversizedYamlFileIsRefusedBeforeReading) {
  const std::string path = this->path("big.yaml");
  {
    std::ofstream out(path);
    out << "name: x\n";
    std::filesystem::resize_file(path, kMaxYamlFileBytes + 1);
  }
  const std::string message = sag_test::inputErrorOf([&] { loadHandModel(path); });
  EXPECT_TRUE(contains(message, "larger than the limit of 1048576 bytes")) << message;
}

TEST(InputValidation, CalibrationHugeFocalLengthIsRefused) {
  const std::string message =
      calibrationError("data: \\[300, 0, 160, 0, 300,", "data: [1e30, 0, 160, 0, 300,");
  EXPECT_TRUE(contains(message, "calibration file cam.yaml:3: key 'camera_matrix'")) << message;
  EXPECT_TRUE(contains(message, "focal length outside [1, 1e+06] pixels")) << message;
}

TEST(InputValidation, CalibrationPrincipalPointAndSkewAreRangeChecked) {
  std::string message = calibrationError("0, 0, 160, 0, 300, 120,", "0, 0, -5000, 0, 300, 120,");
  EXPECT_TRUE(contains(message, "calibration file cam.yaml:3: key 'camera_matrix'")) << message;
  EXPECT_TRUE(contains(message, "principal point (cx -5000, cy 120) outside [-320, 640]"))
      << message;
  message = calibrationError("0, 0, 160, 0, 300, 120,", "0, 0, 160, 0, 300, 1e300,");
  EXPECT_TRUE(contains(message, "principal point (cx 160, cy 1e+300)")) << message;
  message = calibrationError("\\[300, 0, 160,", "[300, 1e6, 160,");
  EXPECT_TRUE(contains(message, "key 'camera_matrix'")) << message;
  EXPECT_TRUE(contains(message, "skew K(0,1) = 1e+06 exceeds the focal length fx = 300"))
      << message;
}

TEST(InputValidation, CalibrationHugeImageIsRefused) {
  const std::string message = calibrationError("image_width: 320", "image_width: 2000000000");
  EXPECT_TRUE(contains(message, "key 'image_width'")) << message;
  EXPECT_TRUE(contains(message, "exceeds the limit")) << message;
}

TEST(InputValidation, CalibrationThreeCoefficientsAreRefused) {
  const std::string message =
      calibrationError("cols: 5, data: \\[0, 0, 0, 0, 0\\]", "cols: 3, data: [0.1, 0, 0]");
  EXPECT_TRUE(contains(message, "key 'distortion_coefficients'")) << message;
  EXPECT_TRUE(contains(message, "3 distortion coefficients")) << message;
}

TEST(InputValidation, ValidateCameraNamesTheCameraForABadDistortionCount) {
  Camera camera = sag_test::fiveCameraRig()[0];
  camera.name = "left";
  camera.distortion = {0.1, 0.0, 0.0};
  const std::string message = sag_test::inputErrorOf([&] { validateCamera(camera); });
  EXPECT_TRUE(contains(message, "camera 'left': 3 distortion coefficients")) << message;
}

// Distortion coefficients that are finite but wild (1e6) cannot be inverted over the image and are
// refused with the camera's name; real lenses' coefficients (barrel, pincushion, rational) pass.
TEST(InputValidation, WildDistortionCoefficientsAreRefused) {
  Camera camera = sag_test::fiveCameraRig()[0];
  camera.name = "left";
  for (const std::vector<double>& real :
       {std::vector<double>{-0.35, 0.12, 0.001, -0.001, -0.02},
        std::vector<double>{0.1, 0.2, 0.003, 0.004, 0.5, 0.06, 0.07, 0.08},
        std::vector<double>{0.25, -0.1, 0.0, 0.0, 0.0}}) {
    camera.distortion = real;
    EXPECT_NO_THROW(checkDistortionInvertible(camera, "camera 'left'"));
  }
  camera.distortion = {1e6, -1e6, 0.0, 0.0, 1e9};
  const std::string message =
      sag_test::inputErrorOf([&] { checkDistortionInvertible(camera, "camera 'left'"); });
  EXPECT_TRUE(contains(message, "camera 'left': the distortion coefficients cannot be inverted"))
      << message;
  // Session 34: a rational lens that folds over (k1 0.1, k4 100: the distorted radius rises to
  // 0.05 at r 0.1, then falls) passed the grid's round trip, and tracking went on with rays
  // 87-89.9 deg off the axis.
  camera.distortion = {0.1, 0.0, 0.0, 0.0, 0.0, 100.0, 0.0, 0.0};
  const std::string folded =
      sag_test::inputErrorOf([&] { checkDistortionInvertible(camera, "camera 'left'"); });
  EXPECT_TRUE(contains(folded,
                       "camera 'left': the distortion coefficients cannot be inverted over the "
                       "image (the lens folds the image over: its radial mapping stops growing "))
      << folded;
}

TEST(InputValidation, RigCamerasAtOnePointAreRefused) {
  const std::string message = rigError(R"(root_frame: world
cameras:
  - {name: cam0, calibration: c.yaml, translation: [0, 0, 0], rotation: [0, 0, 0, 1]}
  - {name: cam1, calibration: c.yaml, translation: [0, 0, 0], rotation: [1, 0, 0, 0]}
)");
  EXPECT_TRUE(contains(message, "rig file rig.yaml:4: key 'cameras[1].translation'")) << message;
  EXPECT_TRUE(contains(message, "camera 'cam1' is at the same point as camera 'cam0'")) << message;
}

TEST(InputValidation, RigCameraNameMustBeSafeAsTopicName) {
  const std::string message = rigError(R"(root_frame: world
cameras:
  - {name: ../../etc, calibration: c.yaml, translation: [0, 0, 0], rotation: [0, 0, 0, 1]}
)");
  EXPECT_TRUE(
      contains(message, "rig.yaml:3: key 'cameras[0].name': '../../etc' is not a safe camera name"))
      << message;
  EXPECT_TRUE(contains(rigError("root_frame: /world\ncameras: []\n"), "not a safe frame name"));
}

TEST(InputValidation, MotionTinyIntervalIsRefusedWithoutSampling) {
  const HandModel model = loadHandModel(sag_test::modelPath("sag"));
  const auto motionError = [&](const std::string& random) {
    return sag_test::inputErrorOf([&] {
      studio::parseMotion(
          "keyframes:\n  - {time: 0, position: [0, 0, 0.15]}\nduration: 3600\n" + random, "m.yaml",
          model, 1);
    });
  };
  std::string message = motionError("random: {keyframes: {from: 0, to: 10, interval: 1e-9}}\n");
  EXPECT_TRUE(contains(message, "motion m.yaml:4: key 'random.keyframes.interval'")) << message;
  EXPECT_TRUE(contains(message, "must be at least 1 ms")) << message;
  // 3.6 million keyframes are counted, not drawn.
  message = motionError("random: {keyframes: {from: 0, to: 3600, interval: 0.001}}\n");
  EXPECT_TRUE(contains(message, "more than the limit of 10000")) << message;
}

TEST(InputValidation, MotionAtTheKeyframeLimitIsDrawnAndSampled) {
  // 10 000 keyframes (1 explicit + 9 999 drawn over an hour): at the limit, so they are drawn,
  // spaced and sampled, and interpolation still passes through them (a 150-byte input that cost
  // the motion fuzz target about 10^8 operations when spacing and poses scanned every keyframe).
  const HandModel model = loadHandModel(sag_test::modelPath("sag"));
  const studio::Motion motion = studio::parseMotion(
      "keyframes:\n  - {time: 0, position: [0, 0, 0.15]}\nduration: 3600\n"
      "random: {keyframes: {from: 0.36, to: 3599.64, interval: 0.36, position: [0.05, 0.05, "
      "0.05], joints: 1}}\n",
      "m.yaml", model, 1);
  EXPECT_EQ(motion.keyframes.size(), 10000u);
  for (std::size_t k = 0; k < motion.keyframes.size(); k += 997) {
    const studio::MotionKeyframe& key = motion.keyframes[k];
    const Pose pose = motion.poseAt(key.time);
    EXPECT_NEAR((pose.translation - key.position).norm(), 0.0, 1e-12) << "keyframe " << k;
    EXPECT_TRUE(pose.toVector().allFinite());
  }
}

TEST(InputValidation, SafeNames) {
  EXPECT_TRUE(isSafeName("cam0"));
  EXPECT_TRUE(isSafeName("left_camera_2"));
  for (const char* bad : {"", "../../etc", "a/b", "0cam", "cam 0", "cam-0", "_x"}) {
    EXPECT_FALSE(isSafeName(bad)) << bad;
  }
}
