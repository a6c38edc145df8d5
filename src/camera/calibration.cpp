#include "sag_hand_tracker/camera/calibration.h"

#include <yaml-cpp/yaml.h>

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

namespace fs = std::filesystem;

// "source:line: problem" (line 1-based) when the node has a position, else "source: problem".
[[noreturn]] void fail(const std::string& source, const YAML::Mark& mark,
                       const std::string& problem) {
  std::ostringstream message;
  message << source;
  if (!mark.is_null() && mark.line >= 0) message << ":" << mark.line + 1;
  message << ": " << problem;
  throw InputError(message.str());
}

[[noreturn]] void fail(const std::string& source, const YAML::Node& node,
                       const std::string& problem) {
  fail(source, node.Mark(), problem);
}

std::string readTextFile(const std::string& path, const std::string& what) {
  std::error_code error;
  if (!fs::exists(path, error)) throw InputError(path + ": " + what + " does not exist");
  if (fs::is_directory(path, error)) throw InputError(path + ": " + what + " is a directory");
  std::ifstream file(path, std::ios::binary);
  if (!file) throw InputError(path + ": cannot open " + what);
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

void writeTextFile(const std::string& path, const std::string& text, const std::string& what) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  if (!file) throw InputError(path + ": cannot write " + what);
  file << text;
  file.close();
  if (!file) throw InputError(path + ": error while writing " + what);
}

YAML::Node parseYaml(const std::string& text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::ParserException& error) {
    fail(source, error.mark, "malformed YAML: " + error.msg);
  }
  if (!root.IsMap()) fail(source, root, "expected a YAML map at the top level");
  return root;
}

const YAML::Node require(const YAML::Node& map, const std::string& key, const std::string& source,
                         const std::string& where = "") {
  const YAML::Node value = map[key];
  if (!value) fail(source, map, "missing key '" + where + key + "'");
  return value;
}

double toDouble(const YAML::Node& node, const std::string& source, const std::string& what) {
  double value = 0.0;
  try {
    if (!node.IsScalar()) throw YAML::BadConversion(node.Mark());
    value = node.as<double>();
  } catch (const YAML::BadConversion&) {
    fail(source, node, "'" + what + "' must be a number");
  }
  if (!std::isfinite(value)) fail(source, node, "'" + what + "' must be finite");
  return value;
}

int toInt(const YAML::Node& node, const std::string& source, const std::string& what) {
  try {
    if (!node.IsScalar()) throw YAML::BadConversion(node.Mark());
    return node.as<int>();
  } catch (const YAML::BadConversion&) {
    fail(source, node, "'" + what + "' must be an integer");
  }
}

std::string toString(const YAML::Node& node, const std::string& source, const std::string& what) {
  if (!node.IsScalar()) fail(source, node, "'" + what + "' must be a string");
  return node.Scalar();
}

std::vector<double> toNumbers(const YAML::Node& node, const std::string& source,
                              const std::string& what) {
  if (!node.IsSequence()) fail(source, node, "'" + what + "' must be a list of numbers");
  std::vector<double> values;
  for (std::size_t i = 0; i < node.size(); ++i) {
    values.push_back(toDouble(node[i], source, what + "[" + std::to_string(i) + "]"));
  }
  return values;
}

// A {rows, cols, data} matrix; expected_rows/cols < 0 accept any size.
std::vector<double> readMatrix(const YAML::Node& map, const std::string& key,
                               const std::string& source, int expected_rows, int expected_cols) {
  const YAML::Node matrix = require(map, key, source);
  if (!matrix.IsMap()) fail(source, matrix, "'" + key + "' must be a map with rows, cols and data");
  const int rows = toInt(require(matrix, "rows", source, key + "."), source, key + ".rows");
  const int cols = toInt(require(matrix, "cols", source, key + "."), source, key + ".cols");
  const std::vector<double> data =
      toNumbers(require(matrix, "data", source, key + "."), source, key + ".data");
  if ((expected_rows >= 0 && rows != expected_rows) ||
      (expected_cols >= 0 && cols != expected_cols)) {
    fail(source, matrix,
         "'" + key + "' must be " + std::to_string(expected_rows) + "x" +
             std::to_string(expected_cols) + ", got " + std::to_string(rows) + "x" +
             std::to_string(cols));
  }
  if (rows < 0 || cols < 0 || static_cast<std::size_t>(rows) * cols != data.size()) {
    fail(source, matrix,
         "'" + key + "' has " + std::to_string(data.size()) + " values for " +
             std::to_string(rows) + "x" + std::to_string(cols));
  }
  return data;
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
std::string formatString(const std::string& value) {
  YAML::Emitter out;
  out << value;
  return out.c_str();
}

void writeMatrix(std::ostream& out, const std::string& key, int rows, int cols,
                 const std::vector<double>& data) {
  out << key << ":\n  rows: " << rows << "\n  cols: " << cols << "\n  data: " << formatList(data)
      << "\n";
}

void checkIntrinsics(const Eigen::Matrix3d& K, const std::string& source, const YAML::Node& node) {
  if (!(K(0, 0) > 0.0) || !(K(1, 1) > 0.0)) {
    fail(source, node,
         "camera_matrix has a zero or negative focal length (fx " + formatNumber(K(0, 0)) +
             ", fy " + formatNumber(K(1, 1)) + ")");
  }
  if (K(1, 0) != 0.0 || K(2, 0) != 0.0 || K(2, 1) != 0.0 || std::abs(K(2, 2) - 1.0) > 1e-9) {
    fail(source, node, "camera_matrix is not an intrinsic matrix (its last row must be 0 0 1)");
  }
}

Eigen::Vector3d readVector3(const YAML::Node& map, const std::string& key,
                            const std::string& source, const std::string& where) {
  const YAML::Node node = require(map, key, source, where);
  const std::vector<double> values = toNumbers(node, source, where + key);
  if (values.size() != 3) fail(source, node, "'" + where + key + "' must have 3 values [x, y, z]");
  return Eigen::Vector3d(values[0], values[1], values[2]);
}

Eigen::Quaterniond readQuaternion(const YAML::Node& map, const std::string& key,
                                  const std::string& source, const std::string& where) {
  const YAML::Node node = require(map, key, source, where);
  const std::vector<double> values = toNumbers(node, source, where + key);
  if (values.size() != 4) {
    fail(source, node, "'" + where + key + "' must be a quaternion [qx, qy, qz, qw]");
  }
  const Eigen::Quaterniond q(values[3], values[0], values[1], values[2]);
  if (std::abs(q.norm() - 1.0) > 1e-3) {
    fail(source, node,
         "'" + where + key + "' is not a unit quaternion (norm " + formatNumber(q.norm()) + ")");
  }
  return q.normalized();
}

}  // namespace

std::string opticalFrame(const std::string& camera_name) { return camera_name + "_optical_frame"; }

Camera parseCameraCalibration(const std::string& yaml_text, const std::string& source) {
  const YAML::Node root = parseYaml(yaml_text, source);
  Camera camera;
  const YAML::Node width = require(root, "image_width", source);
  const YAML::Node height = require(root, "image_height", source);
  camera.width = toInt(width, source, "image_width");
  camera.height = toInt(height, source, "image_height");
  if (camera.width <= 0) fail(source, width, "image_width must be positive");
  if (camera.height <= 0) fail(source, height, "image_height must be positive");
  if (root["camera_name"]) camera.name = toString(root["camera_name"], source, "camera_name");

  const std::vector<double> k = readMatrix(root, "camera_matrix", source, 3, 3);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) camera.K(r, c) = k[3 * r + c];
  }
  checkIntrinsics(camera.K, source, root["camera_matrix"]);

  std::string model = "plumb_bob";
  if (root["distortion_model"]) {
    model = toString(root["distortion_model"], source, "distortion_model");
  }
  if (root["distortion_coefficients"]) {
    camera.distortion = readMatrix(root, "distortion_coefficients", source, 1, -1);
  }
  const YAML::Node model_node = root["distortion_model"] ? root["distortion_model"] : root;
  if (model == "plumb_bob") {
    if (camera.distortion.size() > 5) {
      fail(source, model_node,
           "plumb_bob takes at most 5 distortion coefficients, got " +
               std::to_string(camera.distortion.size()));
    }
  } else if (model == "rational_polynomial") {
    if (camera.distortion.size() > 8) {
      fail(source, model_node,
           "rational_polynomial takes at most 8 distortion coefficients, got " +
               std::to_string(camera.distortion.size()));
    }
  } else {
    fail(source, model_node,
         "unsupported distortion_model '" + model + "' (plumb_bob or rational_polynomial)");
  }
  if (root["rectification_matrix"]) readMatrix(root, "rectification_matrix", source, 3, 3);
  if (root["projection_matrix"]) readMatrix(root, "projection_matrix", source, 3, 4);
  return camera;
}

Camera loadCameraCalibration(const std::string& path) {
  return parseCameraCalibration(readTextFile(path, "calibration file"), path);
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
  out << "camera_name: " << formatString(camera.name) << "\n";
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

CameraRig loadCameraRig(const std::string& path) {
  const YAML::Node root = parseYaml(readTextFile(path, "rig file"), path);
  CameraRig rig;
  rig.root_frame = toString(require(root, "root_frame", path), path, "root_frame");
  if (rig.root_frame.empty()) fail(path, root["root_frame"], "root_frame is empty");
  const YAML::Node cameras = require(root, "cameras", path);
  if (!cameras.IsSequence() || cameras.size() == 0) {
    fail(path, cameras, "'cameras' must be a non-empty list");
  }
  const fs::path directory = fs::path(path).parent_path();
  std::set<std::string> names;
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const YAML::Node entry = cameras[i];
    const std::string where = "cameras[" + std::to_string(i) + "].";
    if (!entry.IsMap()) fail(path, entry, "'" + where + "' must be a map");
    const YAML::Node name_node = require(entry, "name", path, where);
    const std::string name = toString(name_node, path, where + "name");
    if (name.empty()) fail(path, name_node, "'" + where + "name' is empty");
    if (!names.insert(name).second) fail(path, name_node, "camera '" + name + "' appears twice");
    const YAML::Node file_node = require(entry, "calibration", path, where);
    fs::path file = toString(file_node, path, where + "calibration");
    if (file.is_relative()) file = directory / file;
    const Eigen::Vector3d translation = readVector3(entry, "translation", path, where);
    const Eigen::Quaterniond rotation = readQuaternion(entry, "rotation", path, where);

    std::error_code error;
    if (!fs::is_regular_file(file, error)) {
      fail(path, file_node,
           "calibration file '" + file.string() + "' of camera '" + name + "' does not exist");
    }
    Camera camera = loadCameraCalibration(file.string());
    camera.name = name;
    Eigen::Isometry3d root_to_optical = Eigen::Isometry3d::Identity();
    root_to_optical.linear() = rotation.toRotationMatrix();
    root_to_optical.translation() = translation;
    camera.world_to_camera = root_to_optical.inverse();
    rig.cameras.push_back(camera);
  }
  return rig;
}

void saveCameraRig(const std::string& path, const CameraRig& rig) {
  const fs::path directory = fs::path(path).parent_path();
  std::set<std::string> names;
  std::ostringstream out;
  out << "# Camera rig: the transform root_frame -> <name>_optical_frame of every camera, as tf\n"
      << "# publishes it (translation in metres, rotation as quaternion [qx, qy, qz, qw]), and\n"
      << "# its camera_calibration_parsers file relative to this file.\n";
  out << "root_frame: " << formatString(rig.root_frame) << "\n";
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
    out << "  - name: " << formatString(camera.name) << "\n";
    out << "    calibration: " << formatString(file) << "\n";
    out << "    translation: " << formatList({t.x(), t.y(), t.z()}) << "\n";
    out << "    rotation: " << formatList({q.x(), q.y(), q.z(), q.w()}) << "\n";
  }
  writeTextFile(path, out.str(), "rig file");
}

}  // namespace sag_hand_tracker
