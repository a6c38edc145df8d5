// Forward kinematics: pose -> bone frames -> Gaussians and fingertips in the root (world) frame.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <vector>

#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/pose.h"

namespace sag_hand_tracker {

// A Gaussian in the root frame.
struct WorldGaussian {
  Eigen::Vector3d mean;
  Eigen::Matrix3d cov;
};

// Everything the energy needs about the posed skeleton.
struct PosedHand {
  std::vector<Eigen::Isometry3d> bone_frames;  // bone frame -> root frame, per bone
  std::vector<WorldGaussian> gaussians;        // per model Gaussian
  // Per parameter: the motion it causes, as a world axis and a pivot. Translation parameters move
  // along `axis` (pivot unused); rotation parameters turn about `axis` through `pivot`.
  std::array<Eigen::Vector3d, kNumDof> dof_axis;
  std::array<Eigen::Vector3d, kNumDof> dof_pivot;
};

PosedHand forwardKinematics(const HandModel& model, const Pose& pose);

// The five fingertip positions, thumb..pinky, in the root frame (metres).
using Fingertips = std::array<Eigen::Vector3d, kNumFingers>;

// Fingertip positions (thumb..pinky): the distal Gaussian's mean plus its 1-sigma extent along the
// distal bone axis (doc/design.md section 4).
Fingertips fingertips(const HandModel& model, const PosedHand& hand);
Fingertips fingertips(const HandModel& model, const Pose& pose);

// An open, flat hand (all joints at 0 clamped into the limits) at the given root pose.
Pose neutralPose(const HandModel& model, const Eigen::Vector3d& translation,
                 const Eigen::Matrix3d& rotation);

}  // namespace sag_hand_tracker
