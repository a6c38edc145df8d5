#include "sag_hand_tracker/model/hand_model.h"

#include <yaml-cpp/yaml.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

#include "sag_hand_tracker/util/number_text.h"
#include "sag_hand_tracker/util/yaml_reader.h"

namespace sag_hand_tracker {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

Eigen::Matrix3d rpyDegrees(const Eigen::Vector3d& rpy) { return rpyRotation(rpy * kDegToRad); }

// Reads one model document (yaml_reader.h: every error names the file, the line and the key).
class ModelParser {
 public:
  explicit ModelParser(const YamlDocument& document) : document_(document) {}

  HandModel parse() {
    const YamlValue root = document_.root();
    // A misspelt top-level key was ignored without a word (`colors: fitted` tracked with the
    // colours learnt again and the generic skin gate).
    root.allowOnly(
        {"name", "handedness", "projection", "colours", "bones", "gaussians", "fingertips"});
    HandModel model;
    const YamlValue name = root["name"];
    model.name = name.text();
    // The name is written back by calibrate_hand; a control character has no place in it.
    if (std::any_of(model.name.begin(), model.name.end(), isControlCharacter)) {
      name.fail("must be printable text (no control characters)");
    }
    const YamlValue handedness = root["handedness"];
    if (handedness.text() == "right") {
      model.handedness = Handedness::kRight;
    } else if (handedness.text() == "left") {
      model.handedness = Handedness::kLeft;
    } else {
      handedness.fail("must be 'right' or 'left', not '" + handedness.text() + "'");
    }
    const YamlValue projection = root["projection"];
    if (projection.text() == "perspective") {
      model.projection = ProjectionMode::kPerspective;
    } else if (projection.text() == "scaled_orthographic") {
      model.projection = ProjectionMode::kScaledOrthographic;
    } else {
      projection.fail("must be 'perspective' or 'scaled_orthographic', not '" + projection.text() +
                      "'");
    }
    if (root.has("colours")) {
      const YamlValue colours = root["colours"];
      if (colours.text() == "fitted") {
        model.colours_fitted = true;
      } else if (colours.text() != "model") {
        colours.fail("must be 'model' or 'fitted', not '" + colours.text() + "'");
      }
    }
    const YamlValue bones = root["bones"];
    parseBones(bones, &model);
    if (model.joints.size() != static_cast<std::size_t>(kNumJointDof)) {
      bones.fail("wrong number of DOF: the model has " + std::to_string(6 + model.joints.size()) +
                 ", the tracker needs " + std::to_string(kNumDof) + " (6 root + " +
                 std::to_string(kNumJointDof) + " joint angles)");
    }
    parseGaussians(root["gaussians"], &model);
    parseFingertips(root["fingertips"], &model);
    // The parser bounds every value validateHandModel checks; should one still fail, the error
    // names the file: "hand model <file>: <problem>".
    try {
      validateHandModel(model);
    } catch (const InputError& e) {
      document_.fail(0, "", e.what());
    }
    return model;
  }

 private:
  // Roll, pitch, yaw in degrees (zero when absent), each within one turn either way: 1e308 deg
  // passed as finite and turned into whatever sin and cos give such a number.
  static Eigen::Vector3d anglesDegrees(const YamlValue& node, const std::string& key) {
    if (!node.has(key)) return Eigen::Vector3d::Zero();
    const YamlValue value = node[key];
    const Eigen::Vector3d angles = value.vector3();
    if (!(angles.cwiseAbs().maxCoeff() <= 360.0)) {
      value.fail("angles must be within [-360, 360] degrees");
    }
    return angles;
  }

  void parseBones(const YamlValue& bones, HandModel* model) {
    const std::size_t count = bones.size(kMaxModelBones);
    std::set<std::string> dof_names;
    for (std::size_t b = 0; b < count; ++b) {
      const YamlValue node = bones[b];
      node.allowOnly({"name", "parent", "offset", "rest_rpy_deg", "length", "dofs"});
      Bone bone;
      const YamlValue name = node["name"];
      bone.name = name.text();
      if (!isSafeName(bone.name))
        name.fail("'" + bone.name + "' is not a safe frame name" + kNameRule);
      if (bone_index_.count(bone.name)) name.fail("bone '" + bone.name + "' defined twice");
      const std::string parent = node.textOr("parent", "");
      if (!parent.empty()) {
        const auto it = bone_index_.find(parent);
        if (it == bone_index_.end()) {
          node["parent"].fail("bone '" + parent + "' is not defined before '" + bone.name + "'");
        }
        bone.parent = it->second;
      } else if (!model->bones.empty()) {
        node.get("parent").fail("only the first bone (the palm) may be the root");
      }
      bone.offset = node["offset"].vector3();
      if (!(bone.offset.norm() <= kMaxLengthMetres)) {
        node["offset"].fail("is more than " + std::to_string(kMaxLengthMetres) +
                            " m from its parent's origin");
      }
      bone.rest_rotation = rpyDegrees(anglesDegrees(node, "rest_rpy_deg"));
      bone.length = node.has("length") ? node["length"].number(0.0, kMaxLengthMetres) : 0.0;
      if (node.has("dofs")) {
        const YamlValue dofs = node["dofs"];
        const std::size_t dof_count = dofs.size(kNumJointDof);
        for (std::size_t d = 0; d < dof_count; ++d) {
          const YamlValue dof_node = dofs[d];
          dof_node.allowOnly({"name", "axis", "min_deg", "max_deg"});
          JointDof dof;
          const YamlValue dof_name = dof_node["name"];
          dof.name = dof_name.text();
          if (!isSafeName(dof.name)) {
            dof_name.fail("'" + dof.name + "' is not a safe joint name" + kNameRule);
          }
          if (!dof_names.insert(dof.name).second) {
            dof_name.fail("DOF '" + dof.name + "' defined twice");
          }
          dof.bone = static_cast<int>(model->bones.size());
          // A leading '-' reverses the axis (mirrored models, see mirrorHandModel).
          const YamlValue axis = dof_node["axis"];
          const bool negative = !axis.text().empty() && axis.text()[0] == '-';
          const std::string name = negative ? axis.text().substr(1) : axis.text();
          if (name == "x") {
            dof.axis = Eigen::Vector3d::UnitX();
          } else if (name == "y") {
            dof.axis = Eigen::Vector3d::UnitY();
          } else if (name == "z") {
            dof.axis = Eigen::Vector3d::UnitZ();
          } else {
            axis.fail("must be x, y or z (or -x, -y, -z), not '" + axis.text() + "'");
          }
          if (negative) dof.axis = -dof.axis;
          dof.min = dof_node["min_deg"].number(-360.0, 360.0) * kDegToRad;
          dof.max = dof_node["max_deg"].number(-360.0, 360.0) * kDegToRad;
          if (!(dof.min <= dof.max)) dof_node["min_deg"].fail("must not exceed max_deg");
          bone.joint_dofs.push_back(static_cast<int>(model->joints.size()));
          model->joints.push_back(dof);
        }
      }
      bone_index_[bone.name] = static_cast<int>(model->bones.size());
      model->bones.push_back(bone);
    }
  }

  int boneIndex(const YamlValue& node) {
    const std::string name = node.text();
    const auto it = bone_index_.find(name);
    if (it == bone_index_.end()) node.fail("unknown bone '" + name + "'");
    return it->second;
  }

  void parseGaussians(const YamlValue& gaussians, HandModel* model) {
    const std::size_t count = gaussians.size();
    // Counted before any is parsed: every Gaussian costs the energy, per camera and frame.
    if (count > static_cast<std::size_t>(kMaxModelGaussians)) {
      gaussians.fail("has " + std::to_string(count) + " Gaussians, more than the limit of " +
                     std::to_string(kMaxModelGaussians) +
                     " for a hand model (the SAG model has 17, the SoG model 30)");
    }
    model->gaussians.reserve(count);
    for (std::size_t g = 0; g < count; ++g) {
      const YamlValue node = gaussians[g];
      node.allowOnly({"bone", "mean", "sigma", "rpy_deg", "hsv", "weight"});
      ModelGaussian gaussian;
      gaussian.bone = boneIndex(node["bone"]);
      gaussian.mean = node["mean"].vector3();
      if (!(gaussian.mean.norm() <= kMaxLengthMetres)) {
        node["mean"].fail("is more than " + std::to_string(kMaxLengthMetres) +
                          " m from its bone's origin");
      }
      const YamlValue sigma_node = node["sigma"];
      const Eigen::Vector3d sigma = sigma_node.vector3();
      if (!(sigma.minCoeff() > 0.0)) {
        sigma_node.fail("standard deviations must be positive (covariance not positive definite)");
      }
      // A tiny sigma squares to a covariance validateHandModel finds singular (1e-300: zero).
      if (!(sigma.minCoeff() >= kMinModelSigmaMetres)) {
        sigma_node.fail("standard deviation " + shortNumber(sigma.minCoeff()) +
                        " m is below the limit of " + shortNumber(kMinModelSigmaMetres) +
                        " m (0.1 mm): the covariance would be singular");
      }
      if (!(sigma.maxCoeff() <= kMaxLengthMetres)) {
        sigma_node.fail("standard deviations must be at most " + std::to_string(kMaxLengthMetres) +
                        " m");
      }
      const Eigen::Matrix3d rotation = rpyDegrees(anglesDegrees(node, "rpy_deg"));
      gaussian.cov = rotation * sigma.cwiseAbs2().asDiagonal() * rotation.transpose();
      const YamlValue hsv = node["hsv"];
      gaussian.hsv = hsv.vector3();
      if (!(gaussian.hsv[0] >= 0.0 && gaussian.hsv[0] <= 360.0 && gaussian.hsv[1] >= 0.0 &&
            gaussian.hsv[1] <= 1.0 && gaussian.hsv[2] >= 0.0 && gaussian.hsv[2] <= 1.0)) {
        hsv.fail("must be [h, s, v] with h in [0, 360] degrees and s, v in [0, 1]");
      }
      gaussian.weight = node.has("weight") ? node["weight"].number(1e-6, 1e6) : 1.0;
      model->gaussians.push_back(gaussian);
    }
  }

  void parseFingertips(const YamlValue& tips, HandModel* model) {
    tips.allowOnly({fingerNames().begin(), fingerNames().end()});
    std::map<int, int> finger_of_bone;
    for (int finger = 0; finger < kNumFingers; ++finger) {
      const YamlValue tip = tips[fingerNames()[finger]];
      const int bone = boneIndex(tip);
      // Two fingers on one bone tracked and fitted one finger twice (the same fingertip in two
      // columns); the palm as a fingertip failed only later, in the studio and the fit.
      if (bone == 0) tip.fail("is the palm (the root bone), not a finger's last bone");
      const auto [other, inserted] = finger_of_bone.emplace(bone, finger);
      if (!inserted) {
        tip.fail("bone '" + model->bones[bone].name + "' is already the " +
                 fingerNames()[other->second] + "'s fingertip; each finger needs its own");
      }
      // The fingertip Gaussian: the one on that bone reaching furthest along the bone axis.
      int best = -1;
      double best_reach = -1e9;
      for (size_t g = 0; g < model->gaussians.size(); ++g) {
        const ModelGaussian& gaussian = model->gaussians[g];
        if (gaussian.bone != bone) continue;
        const double reach = gaussian.mean.x() + std::sqrt(gaussian.cov(0, 0));
        if (reach > best_reach) {
          best_reach = reach;
          best = static_cast<int>(g);
        }
      }
      if (best < 0) tip.fail("the fingertip bone has no Gaussian");
      model->fingertip_gaussians[finger] = best;
    }
  }

  // Lengths, offsets and sigmas of a hand are centimetres; a metre is a typo (mm vs m).
  static constexpr double kMaxLengthMetres = 1.0;
  static constexpr const char* kNameRule = " (a letter, then letters, digits or '_')";
  const YamlDocument& document_;
  std::map<std::string, int> bone_index_;
};

}  // namespace

std::vector<std::string> HandModel::parameterNames() const {
  std::vector<std::string> names{"root_tx", "root_ty", "root_tz", "root_rx", "root_ry", "root_rz"};
  for (const JointDof& dof : joints) names.push_back(dof.name);
  return names;
}

int HandModel::jointIndex(const std::string& name) const {
  for (size_t j = 0; j < joints.size(); ++j) {
    if (joints[j].name == name) return static_cast<int>(j);
  }
  return -1;
}

std::array<LongFingerJoints, kNumFingers - 1> longFingerJoints(const HandModel& model) {
  std::array<LongFingerJoints, kNumFingers - 1> joints;
  for (int f = 1; f < kNumFingers; ++f) {
    const std::string finger = fingerNames()[f];
    LongFingerJoints& j = joints[f - 1];
    j.mcp_flex = model.jointIndex(finger + "_mcp_flex");
    j.mcp_abd = model.jointIndex(finger + "_mcp_abd");
    j.pip_flex = model.jointIndex(finger + "_pip_flex");
    j.dip_flex = model.jointIndex(finger + "_dip_flex");
  }
  return joints;
}

std::vector<int> thumbJoints(const HandModel& model) {
  std::vector<int> joints;
  for (size_t j = 0; j < model.joints.size(); ++j) {
    if (model.joints[j].name.rfind("thumb_", 0) == 0) joints.push_back(static_cast<int>(j));
  }
  return joints;
}

std::vector<std::vector<int>> HandModel::ancestorJointDofs() const {
  std::vector<std::vector<int>> result(bones.size());
  for (size_t b = 0; b < bones.size(); ++b) {
    if (bones[b].parent >= 0) result[b] = result[bones[b].parent];
    for (int dof : bones[b].joint_dofs) result[b].push_back(dof);
  }
  return result;
}

void validateHandModel(const HandModel& model) {
  if (model.bones.empty()) throw InputError("the model has no bones");
  if (static_cast<int>(model.joints.size()) != kNumJointDof) {
    throw InputError("wrong number of DOF: the model has " +
                     std::to_string(6 + model.joints.size()) + ", the tracker needs " +
                     std::to_string(kNumDof) + " (6 root + " + std::to_string(kNumJointDof) +
                     " joint angles)");
  }
  for (size_t b = 0; b < model.bones.size(); ++b) {
    const Bone& bone = model.bones[b];
    if ((b == 0) != (bone.parent < 0) || bone.parent >= static_cast<int>(b)) {
      throw InputError("bone '" + bone.name + "' has an invalid parent");
    }
  }
  for (const Bone& bone : model.bones) {
    if (!bone.offset.allFinite() || !bone.rest_rotation.allFinite() ||
        !std::isfinite(bone.length) || bone.length < 0.0) {
      throw InputError("bone '" + bone.name +
                       "': offset, rotation and length must be finite, the length >= 0");
    }
  }
  std::set<std::string> dof_names;
  for (const JointDof& dof : model.joints) {
    if (!(dof.min <= dof.max)) throw InputError("dof '" + dof.name + "': min exceeds max");
    if (!dof_names.insert(dof.name).second) {
      throw InputError("dof '" + dof.name + "' is defined twice");
    }
  }
  if (model.gaussians.size() > static_cast<std::size_t>(kMaxModelGaussians)) {
    throw InputError("the model has " + std::to_string(model.gaussians.size()) +
                     " Gaussians, more than the limit of " + std::to_string(kMaxModelGaussians));
  }
  if (model.gaussians.empty()) throw InputError("the model has no Gaussians");
  for (size_t g = 0; g < model.gaussians.size(); ++g) {
    const ModelGaussian& gaussian = model.gaussians[g];
    const std::string which = "Gaussian " + std::to_string(g);
    if (gaussian.bone < 0 || gaussian.bone >= static_cast<int>(model.bones.size())) {
      throw InputError(which + " is attached to no bone");
    }
    if (!gaussian.cov.allFinite() || (gaussian.cov - gaussian.cov.transpose()).norm() > 1e-12) {
      throw InputError(which + ": covariance is not a finite symmetric matrix");
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(gaussian.cov);
    if (!(eigen.eigenvalues().minCoeff() > 0.0)) {
      throw InputError(which + ": covariance is not positive definite");
    }
    if (!gaussian.mean.allFinite()) throw InputError(which + ": mean is not finite");
    if (!(gaussian.weight > 0.0) || !gaussian.hsv.allFinite()) {
      throw InputError(which + ": weight must be positive and the colour finite");
    }
  }
  for (int finger = 0; finger < kNumFingers; ++finger) {
    if (model.fingertip_gaussians[finger] < 0 ||
        model.fingertip_gaussians[finger] >= static_cast<int>(model.gaussians.size())) {
      throw InputError(std::string("no fingertip Gaussian for the ") + fingerNames()[finger]);
    }
    for (int other = 0; other < finger; ++other) {
      if (model.fingertip_gaussians[other] == model.fingertip_gaussians[finger]) {
        throw InputError(std::string("the ") + fingerNames()[other] + " and the " +
                         fingerNames()[finger] + " have one fingertip Gaussian");
      }
    }
  }
}

HandModel parseHandModel(const std::string& yaml_text, const std::string& source) {
  const YamlDocument document(yaml_text, source, "hand model");
  return ModelParser(document).parse();
}

HandModel loadHandModel(const std::string& path) {
  const YamlDocument document = YamlDocument::fromFile(path, "hand model");
  return ModelParser(document).parse();
}

HandModel loadHandModel(const std::string& path, Handedness handedness) {
  HandModel model = loadHandModel(path);
  return model.handedness == handedness ? model : mirrorHandModel(model);
}

Eigen::Matrix3d rpyRotation(const Eigen::Vector3d& rpy) {
  return (Eigen::AngleAxisd(rpy[2], Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy[1], Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy[0], Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

HandModel scaleHandModel(const HandModel& model, double length_factor, double width_factor) {
  const auto positive = [](double f) { return std::isfinite(f) && f > 0.0; };
  if (!positive(length_factor) || !positive(width_factor)) {
    throw InputError("scaleHandModel: the factors must be positive and finite");
  }
  HandModel scaled = model;
  for (Bone& bone : scaled.bones) {
    bone.offset *= length_factor;
    bone.length *= length_factor;
  }
  for (ModelGaussian& gaussian : scaled.gaussians) {
    const double across = gaussian.bone == 0 ? length_factor : width_factor;
    const Eigen::Vector3d s(length_factor, across, width_factor);
    gaussian.mean *= length_factor;
    gaussian.cov = s.asDiagonal() * gaussian.cov * s.asDiagonal();
  }
  return scaled;
}

HandModel mirrorHandModel(const HandModel& model) {
  // Reflection S across the palm's x-z plane. Points and covariances: S p, S C S. Rotations:
  // S R S. Joint axes are pseudo-vectors: -S a, so that equal angles give mirrored poses.
  const Eigen::Matrix3d S = Eigen::Vector3d(1.0, -1.0, 1.0).asDiagonal();
  HandModel mirrored = model;
  mirrored.handedness =
      model.handedness == Handedness::kRight ? Handedness::kLeft : Handedness::kRight;
  mirrored.name = model.name + "_mirrored";
  for (Bone& bone : mirrored.bones) {
    bone.offset = S * bone.offset;
    bone.rest_rotation = S * bone.rest_rotation * S;
  }
  for (JointDof& dof : mirrored.joints) dof.axis = -(S * dof.axis);
  for (ModelGaussian& gaussian : mirrored.gaussians) {
    gaussian.mean = S * gaussian.mean;
    gaussian.cov = S * gaussian.cov * S;
  }
  return mirrored;
}

namespace {

// Rz(yaw) Ry(pitch) Rx(roll) -> (roll, pitch, yaw) in degrees, as the file's rest_rpy_deg.
Eigen::Vector3d rpyDegreesOf(const Eigen::Matrix3d& rotation) {
  const double pitch = std::asin(std::clamp(-rotation(2, 0), -1.0, 1.0));
  const double roll = std::atan2(rotation(2, 1), rotation(2, 2));
  const double yaw = std::atan2(rotation(1, 0), rotation(0, 0));
  return Eigen::Vector3d(roll, pitch, yaw) / kDegToRad;
}

std::string number(double value) {
  if (std::abs(value) < 1e-12) value = 0.0;
  std::ostringstream out;
  out << std::setprecision(6) << value;
  return out.str();
}

std::string list3(const Eigen::Vector3d& v) {
  return "[" + number(v[0]) + ", " + number(v[1]) + ", " + number(v[2]) + "]";
}

std::string axisName(const Eigen::Vector3d& axis) {
  for (int i = 0; i < 3; ++i) {
    const char* names[] = {"x", "y", "z"};
    if (std::abs(std::abs(axis[i]) - 1.0) < 1e-9) {
      return std::string(axis[i] < 0.0 ? "-" : "") + names[i];
    }
  }
  throw InputError("a joint axis that is not a bone axis (x, y or z) cannot be written");
}

}  // namespace

std::string formatHandModel(const HandModel& model, const std::string& comment) {
  validateHandModel(model);
  std::ostringstream out;
  if (!comment.empty()) {
    std::istringstream lines(comment);
    for (std::string line; std::getline(lines, line);) out << "# " << line << "\n";
  }
  out << "name: " << yamlString(model.name) << "\n";
  out << "handedness: " << (model.handedness == Handedness::kRight ? "right" : "left") << "\n";
  out << "projection: "
      << (model.projection == ProjectionMode::kPerspective ? "perspective" : "scaled_orthographic")
      << "\n";
  if (model.colours_fitted) out << "colours: fitted\n";
  out << "bones:\n";
  for (const Bone& bone : model.bones) {
    out << "  - name: " << bone.name << "\n";
    out << "    parent: \"" << (bone.parent >= 0 ? model.bones[bone.parent].name : "") << "\"\n";
    out << "    offset: " << list3(bone.offset) << "\n";
    out << "    rest_rpy_deg: " << list3(rpyDegreesOf(bone.rest_rotation)) << "\n";
    out << "    length: " << number(bone.length) << "\n";
    if (!bone.joint_dofs.empty()) {
      out << "    dofs:\n";
      for (int j : bone.joint_dofs) {
        const JointDof& dof = model.joints[j];
        out << "      - {name: " << dof.name << ", axis: " << axisName(dof.axis)
            << ", min_deg: " << number(dof.min / kDegToRad)
            << ", max_deg: " << number(dof.max / kDegToRad) << "}\n";
      }
    }
  }
  out << "gaussians:\n";
  for (const ModelGaussian& g : model.gaussians) {
    // sigma along the rotated axes: the eigen-decomposition, each eigenvector assigned to the
    // bone axis it is closest to, as a proper rotation.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(g.cov);
    Eigen::Matrix3d rotation;
    Eigen::Vector3d sigma;
    std::array<bool, 3> used{{false, false, false}};
    for (int axis = 0; axis < 3; ++axis) {
      int best = -1;
      for (int e = 0; e < 3; ++e) {
        if (used[e]) continue;
        if (best < 0 ||
            std::abs(eigen.eigenvectors()(axis, e)) > std::abs(eigen.eigenvectors()(axis, best))) {
          best = e;
        }
      }
      used[best] = true;
      Eigen::Vector3d column = eigen.eigenvectors().col(best);
      if (column[axis] < 0.0) column = -column;
      rotation.col(axis) = column;
      sigma[axis] = std::sqrt(std::max(eigen.eigenvalues()[best], 0.0));
    }
    if (rotation.determinant() < 0.0) rotation.col(2) = -rotation.col(2);
    out << "  - {bone: " << model.bones[g.bone].name << ", mean: " << list3(g.mean);
    const Eigen::Vector3d rpy = rpyDegreesOf(rotation);
    if (rpy.norm() > 1e-6) out << ", rpy_deg: " << list3(rpy);
    out << ", sigma: " << list3(sigma) << ", hsv: " << list3(g.hsv);
    if (g.weight != 1.0) out << ", weight: " << number(g.weight);
    out << "}\n";
  }
  out << "fingertips:\n";
  for (int finger = 0; finger < kNumFingers; ++finger) {
    out << "  " << fingerNames()[finger] << ": "
        << model.bones[model.gaussians[model.fingertip_gaussians[finger]].bone].name << "\n";
  }
  return out.str();
}

std::string resolveModelPath(const std::string& name_or_path, const std::string& config_dir) {
  if (name_or_path == "sag") return config_dir + "/hand_sag_right.yaml";
  if (name_or_path == "sog") return config_dir + "/hand_sog_right.yaml";
  return name_or_path;
}

}  // namespace sag_hand_tracker
