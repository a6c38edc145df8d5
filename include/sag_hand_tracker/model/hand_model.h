// The hand model: a 26-DOF kinematic skeleton with anatomical limits and a set of 3D Gaussians
// fixed to its bones (SAG: 17 anisotropic, SoG baseline: 30 isotropic). Loaded from YAML.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <string>
#include <vector>

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

constexpr int kNumDof = 26;       // 3 root translation + 3 root rotation + 20 finger joints
constexpr int kNumJointDof = 20;  // the finger joints
constexpr int kRootTranslation = 0;
constexpr int kRootRotation = 3;
constexpr int kFirstJointDof = 6;

enum class Handedness { kRight, kLeft };
enum class ProjectionMode { kPerspective, kScaledOrthographic };

// One rotational degree of freedom of a finger joint.
struct JointDof {
  std::string name;
  int bone = -1;                                    // bone it rotates
  Eigen::Vector3d axis = Eigen::Vector3d::UnitY();  // unit axis in the bone's rest frame
  double min = 0.0;                                 // radians
  double max = 0.0;                                 // radians
};

struct Bone {
  std::string name;
  int parent = -1;                                   // -1 for the root (palm)
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // origin in the parent frame (metres)
  Eigen::Matrix3d rest_rotation = Eigen::Matrix3d::Identity();  // relative to the parent
  double length = 0.0;                                          // along the bone's x axis (metres)
  std::vector<int> joint_dofs;  // indices into HandModel::joints, applied in this order
};

// A model Gaussian attached to a bone: mean and covariance in the bone frame.
struct ModelGaussian {
  int bone = -1;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d cov = Eigen::Matrix3d::Identity();  // symmetric positive definite
  Hsv hsv = Hsv::Zero();
  double weight = 1.0;  // w_p^h of paper eq. 8
};

struct HandModel {
  std::string name;
  Handedness handedness = Handedness::kRight;
  ProjectionMode projection = ProjectionMode::kPerspective;
  // The Gaussians' colours were taken from the user's images (calibrate_hand; YAML `colours:
  // fitted`): the tracker keeps them instead of learning its own
  // (TrackerParams::colour_adaptation).
  bool colours_fitted = false;
  std::vector<Bone> bones;       // parents before children; bones[0] is the palm
  std::vector<JointDof> joints;  // kNumJointDof entries, parameter order 6..25
  std::vector<ModelGaussian> gaussians;
  // Per finger (thumb..pinky): index of the Gaussian that defines the fingertip (its mean plus
  // its 1-sigma extent along the bone axis), see fingertips() in kinematics.h.
  std::array<int, kNumFingers> fingertip_gaussians{{-1, -1, -1, -1, -1}};

  // Names of all 26 parameters, in order.
  std::vector<std::string> parameterNames() const;
  // The index (0..kNumJointDof-1) of the joint dof named `name`, or -1 if the model has none.
  int jointIndex(const std::string& name) const;
  // Per bone: the joint dofs (0..kNumJointDof-1) of the bone and all its ancestors.
  std::vector<std::vector<int>> ancestorJointDofs() const;
};

// The joint indices of a long finger (HandModel::jointIndex; -1: the model has no such joint).
struct LongFingerJoints {
  int mcp_flex = -1;
  int mcp_abd = -1;
  int pip_flex = -1;
  int dip_flex = -1;
};
// Index to pinky (fingerNames()[1..4]), looked up by name once for work done per frame.
std::array<LongFingerJoints, kNumFingers - 1> longFingerJoints(const HandModel& model);
// The thumb's joint indices (names beginning "thumb_"), in parameter order.
std::vector<int> thumbJoints(const HandModel& model);

// Loads a model from YAML. Throws InputError naming the file, the key and the line. The file is
// at most kMaxYamlFileBytes, with at most kMaxModelGaussians Gaussians (input_limits.h).
HandModel loadHandModel(const std::string& path);
// Parses a model document; `source` names it in errors.
HandModel parseHandModel(const std::string& yaml_text, const std::string& source);
// As loadHandModel, and mirrors it if `handedness` differs from the file's.
HandModel loadHandModel(const std::string& path, Handedness handedness);

// Rz(yaw) Ry(pitch) Rx(roll) of (roll, pitch, yaw) in radians: the model file's rest_rpy_deg
// convention.
Eigen::Matrix3d rpyRotation(const Eigen::Vector3d& rpy);

// The model scaled about its root (the wrist): every bone offset and length and every Gaussian
// mean times `length_factor`; each Gaussian's covariance in its bone frame by S Sigma S with S =
// diag(length_factor, across, width_factor), `across` being length_factor for the palm (bones[0]:
// its x and y span the palm's length and width) and width_factor for the other bones (x along the
// bone, y and z its thickness). (f, f) gives the whole hand f times as large. Joints, colours and
// weights unchanged. Throws InputError unless both factors are positive and finite.
HandModel scaleHandModel(const HandModel& model, double length_factor, double width_factor);

// The mirror image across the palm's x-z plane: a right hand becomes a left hand. The same joint
// angles give mirrored poses (joint axes transform as pseudo-vectors).
HandModel mirrorHandModel(const HandModel& model);

// Checks the invariants (26 DOF, positive-definite covariances, valid parents, limits ordered)
// and throws InputError naming what is wrong.
void validateHandModel(const HandModel& model);

// The model as a model file (the format loadHandModel reads; loading the text gives the same
// model up to rounding to 6 significant digits), e.g. for calibrate_hand's fitted models.
// `comment` becomes '#' lines at the top. Throws InputError for a model that fails
// validateHandModel.
std::string formatHandModel(const HandModel& model, const std::string& comment = "");

// Resolves "sag", "sog" or a path to a model file, looking in `config_dir` for the built-ins.
std::string resolveModelPath(const std::string& name_or_path, const std::string& config_dir);

}  // namespace sag_hand_tracker
