#include "sag_hand_tracker/model/hand_model.h"

#include <yaml-cpp/yaml.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <sstream>

namespace sag_hand_tracker {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

// Reads one model file; every error names the file, the line and the key.
class ModelParser {
 public:
  explicit ModelParser(std::string path) : path_(std::move(path)) {}

  HandModel parse() {
    std::ifstream file(path_);
    if (!file) throw InputError("hand model '" + path_ + "': cannot open the file");
    YAML::Node root;
    try {
      root = YAML::Load(file);
    } catch (const YAML::Exception& e) {
      throw InputError("hand model '" + path_ + "' line " + std::to_string(e.mark.line + 1) +
                       ": malformed YAML: " + e.msg);
    }
    if (!root.IsMap()) fail(root, "", "the file must be a YAML map");

    HandModel model;
    model.name = scalar<std::string>(root, "name");
    const std::string handedness = scalar<std::string>(root, "handedness");
    if (handedness == "right") {
      model.handedness = Handedness::kRight;
    } else if (handedness == "left") {
      model.handedness = Handedness::kLeft;
    } else {
      fail(root["handedness"], "handedness", "must be 'right' or 'left', not '" + handedness + "'");
    }
    const std::string projection = scalar<std::string>(root, "projection");
    if (projection == "perspective") {
      model.projection = ProjectionMode::kPerspective;
    } else if (projection == "scaled_orthographic") {
      model.projection = ProjectionMode::kScaledOrthographic;
    } else {
      fail(root["projection"], "projection",
           "must be 'perspective' or 'scaled_orthographic', not '" + projection + "'");
    }

    parseBones(sequence(root, "bones"), &model);
    parseGaussians(sequence(root, "gaussians"), &model);
    parseFingertips(map(root, "fingertips"), &model);
    try {
      validateHandModel(model);
    } catch (const InputError& e) {
      throw InputError("hand model '" + path_ + "': " + e.what());
    }
    return model;
  }

 private:
  [[noreturn]] void fail(const YAML::Node& node, const std::string& key, const std::string& what) {
    std::ostringstream out;
    out << "hand model '" << path_ << "'";
    if (node.IsDefined() && node.Mark().line >= 0) out << " line " << node.Mark().line + 1;
    if (!key.empty()) out << ", key '" << key << "'";
    out << ": " << what;
    throw InputError(out.str());
  }

  YAML::Node require(const YAML::Node& parent, const std::string& key) {
    const YAML::Node node = parent[key];
    if (!node.IsDefined() || node.IsNull()) fail(parent, key, "missing");
    return node;
  }
  YAML::Node sequence(const YAML::Node& parent, const std::string& key) {
    YAML::Node node = require(parent, key);
    if (!node.IsSequence()) fail(node, key, "must be a list");
    return node;
  }
  YAML::Node map(const YAML::Node& parent, const std::string& key) {
    YAML::Node node = require(parent, key);
    if (!node.IsMap()) fail(node, key, "must be a map");
    return node;
  }
  template <typename T>
  T scalar(const YAML::Node& parent, const std::string& key) {
    const YAML::Node node = require(parent, key);
    try {
      return node.as<T>();
    } catch (const YAML::Exception&) {
      fail(node, key, "has the wrong type");
    }
  }
  template <typename T>
  T scalarOr(const YAML::Node& parent, const std::string& key, const T& fallback) {
    if (!parent[key].IsDefined()) return fallback;
    return scalar<T>(parent, key);
  }
  Eigen::Vector3d vector3(const YAML::Node& parent, const std::string& key) {
    const YAML::Node node = require(parent, key);
    if (!node.IsSequence() || node.size() != 3) fail(node, key, "must be a list of 3 numbers");
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) {
      try {
        v[i] = node[i].as<double>();
      } catch (const YAML::Exception&) {
        fail(node, key, "must be a list of 3 numbers");
      }
      if (!std::isfinite(v[i])) fail(node, key, "must be finite");
    }
    return v;
  }
  Eigen::Vector3d vector3Or(const YAML::Node& parent, const std::string& key) {
    return parent[key].IsDefined() ? vector3(parent, key) : Eigen::Vector3d::Zero();
  }

  static Eigen::Matrix3d rpyDegrees(const Eigen::Vector3d& rpy) {
    return (Eigen::AngleAxisd(rpy[2] * kDegToRad, Eigen::Vector3d::UnitZ()) *
            Eigen::AngleAxisd(rpy[1] * kDegToRad, Eigen::Vector3d::UnitY()) *
            Eigen::AngleAxisd(rpy[0] * kDegToRad, Eigen::Vector3d::UnitX()))
        .toRotationMatrix();
  }

  void parseBones(const YAML::Node& bones, HandModel* model) {
    for (const YAML::Node& node : bones) {
      Bone bone;
      bone.name = scalar<std::string>(node, "name");
      if (bone_index_.count(bone.name))
        fail(node, "name", "bone '" + bone.name + "' defined twice");
      const std::string parent = scalarOr<std::string>(node, "parent", "");
      if (!parent.empty()) {
        const auto it = bone_index_.find(parent);
        if (it == bone_index_.end()) {
          fail(node, "parent", "bone '" + parent + "' is not defined before '" + bone.name + "'");
        }
        bone.parent = it->second;
      } else if (!model->bones.empty()) {
        fail(node, "parent", "only the first bone (the palm) may be the root");
      }
      bone.offset = vector3Or(node, "offset");
      bone.rest_rotation = rpyDegrees(vector3Or(node, "rest_rpy_deg"));
      bone.length = scalarOr<double>(node, "length", 0.0);
      if (node["dofs"].IsDefined()) {
        for (const YAML::Node& dof_node : sequence(node, "dofs")) {
          JointDof dof;
          dof.name = scalar<std::string>(dof_node, "name");
          dof.bone = static_cast<int>(model->bones.size());
          // A leading '-' reverses the axis (mirrored models, see mirrorHandModel).
          const std::string axis = scalar<std::string>(dof_node, "axis");
          const bool negative = !axis.empty() && axis[0] == '-';
          const std::string name = negative ? axis.substr(1) : axis;
          if (name == "x") {
            dof.axis = Eigen::Vector3d::UnitX();
          } else if (name == "y") {
            dof.axis = Eigen::Vector3d::UnitY();
          } else if (name == "z") {
            dof.axis = Eigen::Vector3d::UnitZ();
          } else {
            fail(dof_node, "axis", "must be x, y or z (or -x, -y, -z), not '" + axis + "'");
          }
          if (negative) dof.axis = -dof.axis;
          dof.min = scalar<double>(dof_node, "min_deg") * kDegToRad;
          dof.max = scalar<double>(dof_node, "max_deg") * kDegToRad;
          if (!(dof.min <= dof.max)) fail(dof_node, "min_deg", "must not exceed max_deg");
          bone.joint_dofs.push_back(static_cast<int>(model->joints.size()));
          model->joints.push_back(dof);
        }
      }
      bone_index_[bone.name] = static_cast<int>(model->bones.size());
      model->bones.push_back(bone);
    }
  }

  int boneIndex(const YAML::Node& node, const std::string& key) {
    const std::string name = scalar<std::string>(node, key);
    const auto it = bone_index_.find(name);
    if (it == bone_index_.end()) fail(node, key, "unknown bone '" + name + "'");
    return it->second;
  }

  void parseGaussians(const YAML::Node& gaussians, HandModel* model) {
    for (const YAML::Node& node : gaussians) {
      ModelGaussian gaussian;
      gaussian.bone = boneIndex(node, "bone");
      gaussian.mean = vector3(node, "mean");
      const Eigen::Vector3d sigma = vector3(node, "sigma");
      if (!(sigma.minCoeff() > 0.0)) {
        fail(node, "sigma",
             "standard deviations must be positive (covariance not positive definite)");
      }
      const Eigen::Matrix3d rotation = rpyDegrees(vector3Or(node, "rpy_deg"));
      gaussian.cov = rotation * sigma.cwiseAbs2().asDiagonal() * rotation.transpose();
      gaussian.hsv = vector3(node, "hsv");
      gaussian.weight = scalarOr<double>(node, "weight", 1.0);
      model->gaussians.push_back(gaussian);
    }
  }

  void parseFingertips(const YAML::Node& tips, HandModel* model) {
    for (int finger = 0; finger < kNumFingers; ++finger) {
      const int bone = boneIndex(tips, fingerNames()[finger]);
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
      if (best < 0) fail(tips, fingerNames()[finger], "the fingertip bone has no Gaussian");
      model->fingertip_gaussians[finger] = best;
    }
  }

  std::string path_;
  std::map<std::string, int> bone_index_;
};

}  // namespace

std::vector<std::string> HandModel::parameterNames() const {
  std::vector<std::string> names{"root_tx", "root_ty", "root_tz", "root_rx", "root_ry", "root_rz"};
  for (const JointDof& dof : joints) names.push_back(dof.name);
  return names;
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
  for (const JointDof& dof : model.joints) {
    if (!(dof.min <= dof.max)) throw InputError("dof '" + dof.name + "': min exceeds max");
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
    if (!(gaussian.weight > 0.0) || !gaussian.hsv.allFinite()) {
      throw InputError(which + ": weight must be positive and the colour finite");
    }
  }
  for (int finger = 0; finger < kNumFingers; ++finger) {
    if (model.fingertip_gaussians[finger] < 0 ||
        model.fingertip_gaussians[finger] >= static_cast<int>(model.gaussians.size())) {
      throw InputError(std::string("no fingertip Gaussian for the ") + fingerNames()[finger]);
    }
  }
}

HandModel loadHandModel(const std::string& path) { return ModelParser(path).parse(); }

HandModel loadHandModel(const std::string& path, Handedness handedness) {
  HandModel model = loadHandModel(path);
  return model.handedness == handedness ? model : mirrorHandModel(model);
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
  out << "name: " << model.name << "\n";
  out << "handedness: " << (model.handedness == Handedness::kRight ? "right" : "left") << "\n";
  out << "projection: "
      << (model.projection == ProjectionMode::kPerspective ? "perspective" : "scaled_orthographic")
      << "\n";
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
