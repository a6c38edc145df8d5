#include "sag_hand_tracker/camera/calibration.h"

#include <yaml-cpp/yaml.h>

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "sag_hand_tracker/util/input_limits.h"
#include "sag_hand_tracker/util/types.h"
#include "sag_hand_tracker/util/yaml_reader.h"

namespace sag_hand_tracker {
namespace {

namespace fs = std::filesystem;

// A {rows, cols, data} matrix; expected_rows/cols < 0 accept any size.
std::vector<double> readMatrix(const YamlValue& matrix, int expected_rows, int expected_cols) {
  if (!matrix.isMap()) matrix.fail("must be a map with rows, cols and data");
  const int rows = matrix["rows"].integer();
  const int cols = matrix["cols"].integer();
  if ((expected_rows >= 0 && rows != expected_rows) ||
      (expected_cols >= 0 && cols != expected_cols)) {
    matrix.fail("must be " + std::to_string(expected_rows) + "x" + std::to_string(expected_cols) +
                ", got " + std::to_string(rows) + "x" + std::to_string(cols));
  }
  const std::vector<double> data = matrix["data"].numbers();
  if (rows < 0 || cols < 0 || static_cast<std::size_t>(rows) * cols != data.size()) {
    matrix.fail("has " + std::to_string(data.size()) + " values for " + std::to_string(rows) + "x" +
                std::to_string(cols));
  }
  return data;
}

void writeTextFile(const std::string& path, const std::string& text, const std::string& what) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw InputError(path + ": cannot write " + what);
  file << text;
  file.close();
  if (!file) throw InputError(path + ": error while writing " + what);
}

// Shortest decimal text that reads back to the same double.
std::string formatNumber(double value) {
  if (value == 0.0) value = 0.0;  // no "-0"
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string formatList(const std::vector<double>& values) {
  std::string text = "[";
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (i > 0) text += ", ";
    text += formatNumber(values[i]);
  }
  return text + "]";
}

// A YAML scalar for a string, quoted when plain style would change its meaning.
void writeMatrix(std::ostream& out, const std::string& key, int rows, int cols,
                 const std::vector<double>& data) {
  out << key << ":\n  rows: " << rows << "\n  cols: " << cols << "\n  data: " << formatList(data)
      << "\n";
}

Eigen::Quaterniond readQuaternion(const YamlValue& value) {
  const std::vector<double> q = value.numbers();
  if (q.size() != 4) value.fail("must be a quaternion [qx, qy, qz, qw]");
  const Eigen::Quaterniond rotation(q[3], q[0], q[1], q[2]);
  if (std::abs(rotation.norm() - 1.0) > 1e-3) {
    value.fail("is not a unit quaternion (norm " + formatNumber(rotation.norm()) + ")");
  }
  return rotation.normalized();
}

const char* const kNameRule = " (a letter, then letters, digits or '_')";

}  // namespace

std::string opticalFrame(const std::string& camera_name) { return camera_name + "_optical_frame"; }

namespace {

Camera readCameraCalibration(const YamlDocument& document) {
  const YamlValue root = document.root();
  Camera camera;
  const YamlValue width = root["image_width"];
  const YamlValue height = root["image_height"];
  camera.width = width.integer();
  camera.height = height.integer();
  if (camera.width <= 0) width.fail("must be positive");
  if (camera.height <= 0) height.fail("must be positive");
  try {
    checkImageSize(camera.width, camera.height, "the camera");
  } catch (const InputError& error) {
    width.fail(error.what());
  }
  camera.name = root.textOr("camera_name", "");

  const YamlValue matrix = root["camera_matrix"];
  const std::vector<double> k = readMatrix(matrix, 3, 3);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) camera.K(r, c) = k[3 * r + c];
  }
  if (!(camera.K(0, 0) > 0.0) || !(camera.K(1, 1) > 0.0)) {
    matrix.fail("has a zero or negative focal length (fx " + formatNumber(camera.K(0, 0)) +
                ", fy " + formatNumber(camera.K(1, 1)) + ")");
  }
  if (camera.K(0, 0) > kMaxFocalLengthPixels || camera.K(1, 1) > kMaxFocalLengthPixels ||
      camera.K(0, 0) < kMinFocalLengthPixels || camera.K(1, 1) < kMinFocalLengthPixels) {
    matrix.fail("has a focal length outside [" + formatNumber(kMinFocalLengthPixels) + ", " +
                formatNumber(kMaxFocalLengthPixels) + "] pixels (fx " +
                formatNumber(camera.K(0, 0)) + ", fy " + formatNumber(camera.K(1, 1)) + ")");
  }
  if (camera.K(1, 0) != 0.0 || camera.K(2, 0) != 0.0 || camera.K(2, 1) != 0.0 ||
      std::abs(camera.K(2, 2) - 1.0) > 1e-9) {
    matrix.fail("is not an intrinsic matrix (its last row must be 0 0 1)");
  }
  try {
    checkPrincipalPointAndSkew(camera, "the camera");
  } catch (const InputError& error) {
    matrix.fail(error.what());
  }

  const YamlValue model_node = root.get("distortion_model");
  const std::string model = root.textOr("distortion_model", "plumb_bob");
  if (root.has("distortion_coefficients")) {
    camera.distortion = readMatrix(root["distortion_coefficients"], 1, -1);
  }
  const std::size_t count = camera.distortion.size();
  if (model == "plumb_bob") {
    if (count > 5) {
      model_node.fail("plumb_bob takes at most 5 distortion coefficients, got " +
                      std::to_string(count));
    }
  } else if (model == "rational_polynomial") {
    // 5 coefficients were taken (padded with zeros) as plumb_bob's.
    if (count != 8) {
      model_node.fail(
          "rational_polynomial has 8 distortion coefficients (k1 k2 p1 p2 k3 k4 k5 "
          "k6), got " +
          std::to_string(count) + "; 5 are plumb_bob's");
    }
  } else {
    model_node.fail("unsupported distortion_model '" + model +
                    "' (plumb_bob or rational_polynomial)");
  }
  try {
    checkDistortionCount(count, "distortion_coefficients");
  } catch (const InputError& error) {
    root.get("distortion_coefficients").fail(error.what());
  }
  try {
    checkDistortionInvertible(camera, "the camera");
  } catch (const InputError& error) {
    root.get("distortion_coefficients").fail(error.what());
  }
  // Not used (the tracker works on raw images with K and D), but checked as camera_info's are:
  // their numbers finite (readMatrix), R a rotation or unset (all zeros).
  if (root.has("rectification_matrix")) {
    const YamlValue node = root["rectification_matrix"];
    const std::vector<double> r = readMatrix(node, 3, 3);
    const std::string problem = rectificationProblem(
        Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(r.data()));
    if (!problem.empty()) node.fail(problem);
  }
  if (root.has("projection_matrix")) readMatrix(root["projection_matrix"], 3, 4);
  return camera;
}

}  // namespace

Camera parseCameraCalibration(const std::string& yaml_text, const std::string& source) {
  return readCameraCalibration(YamlDocument(yaml_text, source, "calibration file"));
}

Camera loadCameraCalibration(const std::string& path) {
  return readCameraCalibration(YamlDocument::fromFile(path, "calibration file"));
}

std::string cameraCalibrationToYaml(const Camera& camera) {
  std::vector<double> distortion = camera.distortion;
  std::string model = "plumb_bob";
  if (distortion.size() > 5) {
    model = "rational_polynomial";
    distortion.resize(8, 0.0);
  } else {
    distortion.resize(5, 0.0);
  }
  std::vector<double> k(9), p(12, 0.0);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      k[3 * r + c] = camera.K(r, c);
      p[4 * r + c] = camera.K(r, c);
    }
  }
  std::ostringstream out;
  out << "image_width: " << camera.width << "\n";
  out << "image_height: " << camera.height << "\n";
  out << "camera_name: " << yamlString(camera.name) << "\n";
  writeMatrix(out, "camera_matrix", 3, 3, k);
  out << "distortion_model: " << model << "\n";
  writeMatrix(out, "distortion_coefficients", 1, static_cast<int>(distortion.size()), distortion);
  writeMatrix(out, "rectification_matrix", 3, 3, {1, 0, 0, 0, 1, 0, 0, 0, 1});
  writeMatrix(out, "projection_matrix", 3, 4, p);
  return out.str();
}

void saveCameraCalibration(const std::string& path, const Camera& camera) {
  writeTextFile(path, cameraCalibrationToYaml(camera), "calibration file");
}

CameraRig parseCameraRig(const std::string& yaml_text, const std::string& source,
                         const CalibrationLoader& load_calibration) {
  const YamlDocument document(yaml_text, source, "rig file");
  const YamlValue root = document.root();
  root.allowOnly({"root_frame", "cameras"});  // a misspelt key was ignored without a word
  CameraRig rig;
  const YamlValue root_frame = root["root_frame"];
  rig.root_frame = root_frame.text();
  if (!isSafeName(rig.root_frame)) {
    root_frame.fail("'" + rig.root_frame + "' is not a safe frame name" + kNameRule);
  }
  const YamlValue cameras = root["cameras"];
  const std::size_t count = cameras.size(kMaxCameras);
  if (count == 0) cameras.fail("must be a non-empty list");
  std::set<std::string> names;
  for (std::size_t i = 0; i < count; ++i) {
    const YamlValue entry = cameras[i];
    entry.allowOnly({"name", "calibration", "translation", "rotation"});
    const YamlValue name_node = entry["name"];
    const std::string name = name_node.text();
    if (!isSafeName(name)) {
      name_node.fail("'" + name + "' is not a safe camera name (it becomes topics and frames)" +
                     kNameRule);
    }
    if (!names.insert(name).second) name_node.fail("camera '" + name + "' appears twice");
    const YamlValue file_node = entry["calibration"];
    const std::string file = file_node.text();
    const Eigen::Vector3d translation = entry["translation"].vector3();
    if (!(translation.cwiseAbs().maxCoeff() <= kMaxRigExtentMetres)) {
      entry["translation"].fail("values must lie within +-" + formatNumber(kMaxRigExtentMetres) +
                                " m");
    }
    const Eigen::Quaterniond rotation = readQuaternion(entry["rotation"]);
    Camera camera;
    try {
      camera = load_calibration(file);
    } catch (const InputError& error) {
      file_node.fail("camera '" + name + "': " + error.what());
    }
    camera.name = name;
    Eigen::Isometry3d root_to_optical = Eigen::Isometry3d::Identity();
    root_to_optical.linear() = rotation.toRotationMatrix();
    root_to_optical.translation() = translation;
    camera.world_to_camera = root_to_optical.inverse();
    for (const Camera& other : rig.cameras) {
      if ((other.centre() - camera.centre()).norm() < kMinCameraSeparation) {
        entry["translation"].fail("camera '" + name + "' is at the same point as camera '" +
                                  other.name + "' (closer than " +
                                  formatNumber(kMinCameraSeparation) + " m)");
      }
    }
    rig.cameras.push_back(camera);
  }
  return rig;
}

CameraRig loadCameraRig(const std::string& path, std::vector<std::string>* calibration_files) {
  const fs::path directory = fs::path(path).parent_path();
  return parseCameraRig(readYamlFileText(path, "rig file"), path, [&](const std::string& name) {
    fs::path file = name;
    if (file.is_relative()) file = directory / file;
    if (calibration_files) calibration_files->push_back(file.string());
    return loadCameraCalibration(file.string());
  });
}

void saveCameraRig(const std::string& path, const CameraRig& rig) {
  const fs::path directory = fs::path(path).parent_path();
  std::set<std::string> names;
  std::ostringstream out;
  out << "# Camera rig: the transform root_frame -> <name>_optical_frame of every camera, as tf\n"
      << "# publishes it (translation in metres, rotation as quaternion [qx, qy, qz, qw]), and\n"
      << "# its camera_calibration_parsers file relative to this file.\n";
  out << "root_frame: " << yamlString(rig.root_frame) << "\n";
  out << "cameras:\n";
  for (const Camera& camera : rig.cameras) {
    if (camera.name.empty()) throw InputError(path + ": a camera of the rig has no name");
    if (!names.insert(camera.name).second) {
      throw InputError(path + ": camera '" + camera.name + "' appears twice");
    }
    const std::string file = camera.name + ".yaml";
    saveCameraCalibration((directory / file).string(), camera);
    const Eigen::Isometry3d root_to_optical = camera.world_to_camera.inverse();
    Eigen::Quaterniond q(root_to_optical.rotation());
    if (q.w() < 0.0) q.coeffs() = -q.coeffs();
    const Eigen::Vector3d t = root_to_optical.translation();
    out << "  - name: " << yamlString(camera.name) << "\n";
    out << "    calibration: " << yamlString(file) << "\n";
    out << "    translation: " << formatList({t.x(), t.y(), t.z()}) << "\n";
    out << "    rotation: " << formatList({q.x(), q.y(), q.z(), q.w()}) << "\n";
  }
  writeTextFile(path, out.str(), "rig file");
}

}  // namespace sag_hand_tracker
