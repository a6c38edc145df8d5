#include <gtest/gtest.h>

#include "test_support/temp_files.h"

#include <filesystem>
#include <fstream>
#include <random>

#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/util/types.h"

using namespace sag_hand_tracker;
namespace fs = std::filesystem;

namespace {

class CalibrationFiles : public sag_test::TempDirTest {};

Camera exampleCamera(const std::string& name) {
  Camera camera;
  camera.name = name;
  camera.width = 320;
  camera.height = 240;
  camera.K << 301.25, 0.0, 159.7, 0.0, 299.875, 121.1, 0.0, 0.0, 1.0;
  camera.distortion = {-0.12, 0.031, 0.0011, -0.0007, 0.1};
  return camera;
}

const char* kValidCalibration = R"(image_width: 320
image_height: 240
camera_name: narrow_stereo
camera_matrix:
  rows: 3
  cols: 3
  data: [300.5, 0, 160.25, 0, 301, 119.75, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [-0.1, 0.02, 0.001, -0.002, 0]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
projection_matrix:
  rows: 3
  cols: 4
  data: [300.5, 0, 160.25, 0, 0, 301, 119.75, 0, 0, 0, 1, 0]
)";

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

}  // namespace

TEST_F(CalibrationFiles, CalibrationReadsCameraCalibrationParsersFormat) {
  const Camera camera = loadCameraCalibration(write("cam.yaml", kValidCalibration));
  EXPECT_EQ(camera.name, "narrow_stereo");
  EXPECT_EQ(camera.width, 320);
  EXPECT_EQ(camera.height, 240);
  EXPECT_DOUBLE_EQ(camera.K(0, 0), 300.5);
  EXPECT_DOUBLE_EQ(camera.K(1, 1), 301.0);
  EXPECT_DOUBLE_EQ(camera.K(0, 2), 160.25);
  EXPECT_DOUBLE_EQ(camera.K(1, 2), 119.75);
  ASSERT_EQ(camera.distortion.size(), 5u);
  EXPECT_DOUBLE_EQ(camera.distortion[0], -0.1);
  EXPECT_DOUBLE_EQ(camera.distortion[3], -0.002);
  EXPECT_TRUE(camera.world_to_camera.matrix().isIdentity(0.0));
}

TEST_F(CalibrationFiles, CalibrationRoundTripIsExact) {
  for (const std::vector<double>& distortion :
       {std::vector<double>{}, std::vector<double>{-0.12, 0.031, 0.0011, -0.0007, 0.1},
        std::vector<double>{0.1, 0.2, 0.003, 0.004, 0.5, 0.06, 0.07, 0.08}}) {
    Camera camera = exampleCamera("cam3");
    camera.distortion = distortion;
    const std::string path = (dir_ / "cam3.yaml").string();
    saveCameraCalibration(path, camera);
    const Camera read = loadCameraCalibration(path);
    EXPECT_EQ(read.name, "cam3");
    EXPECT_EQ(read.width, camera.width);
    EXPECT_EQ(read.height, camera.height);
    EXPECT_EQ(read.K, camera.K);  // shortest round-trip numbers: exact
    std::vector<double> expected = distortion;
    expected.resize(distortion.size() > 5 ? 8 : 5, 0.0);
    EXPECT_EQ(read.distortion, expected);
  }
}

TEST_F(CalibrationFiles, CalibrationWritesEveryKeyOfTheFormat) {
  const std::string text = cameraCalibrationToYaml(exampleCamera("cam0"));
  for (const char* key : {"image_width: 320", "image_height: 240", "camera_name: cam0",
                          "camera_matrix:", "distortion_model: plumb_bob",
                          "distortion_coefficients:", "rectification_matrix:", "projection_matrix:",
                          "data: [301.25, 0, 159.7, 0, 0, 299.875, 121.1, "
                          "0, 0, 0, 1, 0]"}) {
    EXPECT_NE(text.find(key), std::string::npos) << key << " not in\n" << text;
  }
}

TEST_F(CalibrationFiles, CalibrationRigRoundTrip) {
  CameraRig rig;
  rig.root_frame = "studio";
  for (int i = 0; i < 3; ++i) {
    Camera camera = exampleCamera("cam" + std::to_string(i));
    Eigen::Isometry3d root_to_optical = Eigen::Isometry3d::Identity();
    root_to_optical.linear() =
        Eigen::AngleAxisd(0.3 + i, Eigen::Vector3d(1.0, -2.0, 0.5 * i).normalized())
            .toRotationMatrix();
    root_to_optical.translation() = Eigen::Vector3d(0.1 * i, -0.4, 0.75 + i);
    camera.world_to_camera = root_to_optical.inverse();
    rig.cameras.push_back(camera);
  }
  const std::string path = (dir_ / "rig.yaml").string();
  saveCameraRig(path, rig);
  EXPECT_TRUE(fs::exists(dir_ / "cam0.yaml"));
  EXPECT_TRUE(fs::exists(dir_ / "cam2.yaml"));

  const CameraRig read = loadCameraRig(path);
  EXPECT_EQ(read.root_frame, "studio");
  ASSERT_EQ(read.cameras.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(read.cameras[i].name, rig.cameras[i].name);
    EXPECT_EQ(read.cameras[i].K, rig.cameras[i].K);
    EXPECT_EQ(read.cameras[i].distortion, rig.cameras[i].distortion);
    EXPECT_TRUE(read.cameras[i].world_to_camera.matrix().isApprox(
        rig.cameras[i].world_to_camera.matrix(), 1e-12));
  }
}

TEST_F(CalibrationFiles, CalibrationRigTransformIsTheCameraPoseInTheRoot) {
  write("c.yaml", kValidCalibration);
  // cam0_optical_frame at (1, 2, 3), turned by 90 degrees about the root's z axis.
  const std::string rig = write("rig.yaml", R"(root_frame: world
cameras:
  - name: cam0
    calibration: c.yaml
    translation: [1, 2, 3]
    rotation: [0, 0, 0.7071067811865476, 0.7071067811865476]
)");
  const CameraRig read = loadCameraRig(rig);
  ASSERT_EQ(read.cameras.size(), 1u);
  const Camera& camera = read.cameras[0];
  EXPECT_EQ(camera.name, "cam0");  // the rig's name wins over the file's camera_name
  // The camera centre maps to the camera frame's origin ...
  EXPECT_LT((camera.world_to_camera * Eigen::Vector3d(1, 2, 3)).norm(), 1e-12);
  // ... and the root point one metre along the root's y axis is on the camera's -x axis.
  EXPECT_LT((camera.world_to_camera * Eigen::Vector3d(1, 3, 3) - Eigen::Vector3d(1, 0, 0)).norm(),
            1e-12);
}

TEST_F(CalibrationFiles, CalibrationRigFindsCalibrationRelativeToTheRigFile) {
  fs::create_directories(dir_ / "rigs" / "intrinsics");
  write("rigs/intrinsics/a.yaml", kValidCalibration);
  const std::string rig = write("rigs/rig.yaml", R"(root_frame: world
cameras:
  - {name: cam0, calibration: intrinsics/a.yaml, translation: [0, 0, 0], rotation: [0, 0, 0, 1]}
)");
  EXPECT_EQ(loadCameraRig(rig).cameras.at(0).width, 320);
}

TEST_F(CalibrationFiles, CalibrationErrorMissingFile) {
  const std::string path = (dir_ / "absent.yaml").string();
  const std::string message = sag_test::inputErrorOf([&] { loadCameraCalibration(path); });
  EXPECT_NE(message.find(path), std::string::npos) << message;
  EXPECT_NE(message.find("does not exist"), std::string::npos) << message;
  EXPECT_NE(sag_test::inputErrorOf([&] {
              loadCameraRig(path);
            }).find("rig file " + path + ": does not exist"),
            std::string::npos);
}

TEST_F(CalibrationFiles, CalibrationErrorMalformedYamlNamesTheLine) {
  const std::string path =
      write("bad.yaml",
            replaced(kValidCalibration, "camera_name: narrow_stereo", "camera_name: [unclosed"));
  const std::string message = sag_test::inputErrorOf([&] { loadCameraCalibration(path); });
  EXPECT_EQ(message.rfind("calibration file " + path + ":", 0), 0u) << message;
  EXPECT_NE(message.find("malformed YAML"), std::string::npos) << message;
  // The parser reports where it gave up: on or after line 3, where the list opens.
  const int line =
      std::stoi(message.substr(std::string("calibration file ").size() + path.size() + 1));
  EXPECT_GE(line, 3) << message;
}

TEST_F(CalibrationFiles, CalibrationErrorMissingKey) {
  const std::string no_width =
      write("a.yaml", replaced(kValidCalibration, "image_width: 320\n", ""));
  EXPECT_NE(sag_test::inputErrorOf([&] {
              loadCameraCalibration(no_width);
            }).find(no_width + ":1: key 'image_width': missing"),
            std::string::npos);
  const std::string no_data = write(
      "b.yaml",
      replaced(kValidCalibration, "  data: [300.5, 0, 160.25, 0, 301, 119.75, 0, 0, 1]\n", ""));
  const std::string message = sag_test::inputErrorOf([&] { loadCameraCalibration(no_data); });
  EXPECT_NE(message.find("key 'camera_matrix.data': missing"), std::string::npos) << message;
  EXPECT_EQ(message.rfind("calibration file " + no_data + ":5:", 0), 0u) << message;
}

TEST_F(CalibrationFiles, CalibrationErrorZeroFocalLength) {
  const std::string path = write(
      "f.yaml", replaced(kValidCalibration, "data: [300.5, 0, 160.25, 0, 301, 119.75, 0, 0, 1]",
                         "data: [0, 0, 160.25, 0, 301, 119.75, 0, 0, 1]"));
  const std::string message = sag_test::inputErrorOf([&] { loadCameraCalibration(path); });
  EXPECT_NE(message.find(path), std::string::npos) << message;
  EXPECT_NE(message.find("zero or negative focal length"), std::string::npos) << message;
}

TEST_F(CalibrationFiles, CalibrationErrorBadValues) {
  const std::string wrong_count = write(
      "w.yaml", replaced(kValidCalibration, "data: [300.5, 0, 160.25, 0, 301, 119.75, 0, 0, 1]",
                         "data: [300.5, 0, 160.25, 0, 301, 119.75, 0, 0]"));
  EXPECT_NE(sag_test::inputErrorOf([&] {
              loadCameraCalibration(wrong_count);
            }).find("has 8 values for 3x3"),
            std::string::npos);
  const std::string not_number =
      write("n.yaml", replaced(kValidCalibration, "image_height: 240", "image_height: tall"));
  EXPECT_NE(sag_test::inputErrorOf([&] {
              loadCameraCalibration(not_number);
            }).find(":2: key 'image_height': must be an integer"),
            std::string::npos);
  const std::string fisheye = write(
      "e.yaml",
      replaced(kValidCalibration, "distortion_model: plumb_bob", "distortion_model: equidistant"));
  EXPECT_NE(sag_test::inputErrorOf([&] {
              loadCameraCalibration(fisheye);
            }).find("unsupported distortion_model 'equidistant'"),
            std::string::npos);
  const std::string empty = write("empty.yaml", "");
  EXPECT_NE(
      sag_test::inputErrorOf([&] { loadCameraCalibration(empty); }).find("must be a YAML map"),
      std::string::npos);
}

// A rectification matrix that is not a rotation (scaled, mirrored) was read and ignored, and a
// rational_polynomial file with plumb_bob's 5 coefficients was taken as plumb_bob: both are refused
// with the file, the line and the key. NaN or infinity in R or P were already refused (every
// number of the file is finite).
TEST_F(CalibrationFiles, CalibrationErrorRectificationProjectionAndRationalPolynomial) {
  const std::string identity = "data: [1, 0, 0, 0, 1, 0, 0, 0, 1]";
  std::string file =
      write("r0.yaml", replaced(kValidCalibration, identity, "data: [0, 0, 0, 0, 0, 0, 0, 0, 0]"));
  // All zeros is R left unset (the tracker uses K and D only): accepted.
  EXPECT_NO_THROW(loadCameraCalibration(file));
  file =
      write("r2.yaml", replaced(kValidCalibration, identity, "data: [2, 0, 0, 0, 2, 0, 0, 0, 2]"));
  EXPECT_EQ(sag_test::inputErrorOf([&] { loadCameraCalibration(file); }),
            "calibration file " + file +
                ":14: key 'rectification_matrix': is not a rotation (R R^T differs from the "
                "identity by up to 3, det 8)");
  file = write("rnan.yaml",
               replaced(kValidCalibration, identity, "data: [1, 0, 0, 0, .nan, 0, 0, 0, 1]"));
  EXPECT_EQ(sag_test::inputErrorOf([&] { loadCameraCalibration(file); }),
            "calibration file " + file +
                ":16: key 'rectification_matrix.data[4]': must be finite, not '.nan'");
  file = write("pinf.yaml", replaced(kValidCalibration, "data: [300.5, 0, 160.25, 0, 0, 301,",
                                     "data: [300.5, 0, 160.25, 0, 0, .inf,"));
  EXPECT_EQ(sag_test::inputErrorOf([&] { loadCameraCalibration(file); }),
            "calibration file " + file +
                ":20: key 'projection_matrix.data[5]': must be finite, not '.inf'");

  const std::string rational = replaced(kValidCalibration, "distortion_model: plumb_bob",
                                        "distortion_model: rational_polynomial");
  file = write("rational5.yaml", rational);
  EXPECT_EQ(sag_test::inputErrorOf([&] { loadCameraCalibration(file); }),
            "calibration file " + file +
                ":8: key 'distortion_model': rational_polynomial has 8 distortion coefficients (k1 "
                "k2 p1 p2 k3 k4 k5 k6), got 5; 5 are plumb_bob's");
  file = write("rational8.yaml", replaced(replaced(rational, "cols: 5", "cols: 8"),
                                          "data: [-0.1, 0.02, 0.001, -0.002, 0]",
                                          "data: [-0.1, 0.02, 0.001, -0.002, 0, 0.01, 0, 0]"));
  EXPECT_EQ(loadCameraCalibration(file).distortion.size(), 8u);
}

TEST_F(CalibrationFiles, CalibrationErrorNonUnitQuaternion) {
  write("c.yaml", kValidCalibration);
  const std::string rig = write("rig.yaml", R"(root_frame: world
cameras:
  - name: cam0
    calibration: c.yaml
    translation: [1, 2, 3]
    rotation: [0, 0, 0.5, 0.5]
)");
  const std::string message = sag_test::inputErrorOf([&] { loadCameraRig(rig); });
  EXPECT_EQ(message.rfind(
                "rig file " + rig + ":6: key 'cameras[0].rotation': is not a unit quaternion", 0),
            0u)
      << message;
}

TEST_F(CalibrationFiles, CalibrationErrorRigProblems) {
  write("c.yaml", kValidCalibration);
  const std::string missing_calibration = write("r1.yaml", R"(root_frame: world
cameras:
  - name: cam0
    calibration: nowhere.yaml
    translation: [0, 0, 0]
    rotation: [0, 0, 0, 1]
)");
  std::string message = sag_test::inputErrorOf([&] { loadCameraRig(missing_calibration); });
  EXPECT_NE(message.find(missing_calibration +
                         ":4: key 'cameras[0].calibration': camera 'cam0': calibration file"),
            std::string::npos)
      << message;
  EXPECT_NE(message.find("nowhere.yaml: does not exist"), std::string::npos) << message;

  const std::string no_translation = write("r2.yaml", R"(root_frame: world
cameras:
  - name: cam0
    calibration: c.yaml
    rotation: [0, 0, 0, 1]
)");
  message = sag_test::inputErrorOf([&] { loadCameraRig(no_translation); });
  EXPECT_NE(message.find("key 'cameras[0].translation': missing"), std::string::npos) << message;

  const std::string no_root = write("r3.yaml", "cameras: []\n");
  EXPECT_NE(
      sag_test::inputErrorOf([&] { loadCameraRig(no_root); }).find("key 'root_frame': missing"),
      std::string::npos);
  const std::string no_cameras = write("r4.yaml", "root_frame: world\ncameras: []\n");
  EXPECT_NE(sag_test::inputErrorOf([&] {
              loadCameraRig(no_cameras);
            }).find("key 'cameras': must be a non-empty list"),
            std::string::npos);
  const std::string twice = write("r5.yaml", R"(root_frame: world
cameras:
  - {name: cam0, calibration: c.yaml, translation: [0, 0, 0], rotation: [0, 0, 0, 1]}
  - {name: cam0, calibration: c.yaml, translation: [0, 0, 1], rotation: [0, 0, 0, 1]}
)");
  EXPECT_NE(sag_test::inputErrorOf([&] {
              loadCameraRig(twice);
            }).find(":4: key 'cameras[1].name': camera 'cam0' appears twice"),
            std::string::npos);
  // An error inside a camera's calibration file names that file.
  const std::string bad = write("bad.yaml", "image_width: 320\n");
  const std::string bad_calibration = write("r6.yaml", R"(root_frame: world
cameras:
  - {name: cam0, calibration: bad.yaml, translation: [0, 0, 0], rotation: [0, 0, 0, 1]}
)");
  message = sag_test::inputErrorOf([&] { loadCameraRig(bad_calibration); });
  EXPECT_NE(message.find((dir_ / "bad.yaml").string() + ":1: key 'image_height': missing"),
            std::string::npos)
      << message;
}
