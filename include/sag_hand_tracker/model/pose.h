// The 26 pose parameters Theta: root translation and orientation, and 20 joint angles.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "sag_hand_tracker/model/hand_model.h"

namespace sag_hand_tracker {

using PoseVector = Eigen::Matrix<double, kNumDof, 1>;

// Root orientation is kept as a rotation matrix (no gimbal lock); as parameters it is the rotation
// vector (axis * angle). Gradients and optimizer steps for the orientation are taken in the tangent
// space at the current orientation: R <- exp([delta]_x) R (delta in world axes).
struct Pose {
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();   // wrist position in the root frame
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // palm frame to root frame
  Eigen::Matrix<double, kNumJointDof, 1> joints = Eigen::Matrix<double, kNumJointDof, 1>::Zero();

  // Parameters: tx ty tz, rotation vector (3), joints (20).
  PoseVector toVector() const;
  static Pose fromVector(const PoseVector& v);
  // Adds a step: translation and joints additively, orientation as exp([step_rot]_x) * R.
  Pose stepped(const PoseVector& step) const;
  bool allFinite() const;
};

Eigen::Matrix3d rotationFromVector(const Eigen::Vector3d& rotation_vector);
Eigen::Vector3d rotationToVector(const Eigen::Matrix3d& rotation);

// Warm start (paper section 4.4): extrapolate the two previous poses, p + (p - p_prev), the
// orientation by repeating the last relative rotation.
Pose extrapolatePose(const Pose& previous, const Pose& current);

// The pose one frame before `pose` if it had made the rigid motion from `from` to `to` (the same
// turn, applied in the root frame as extrapolatePose repeats it, and the same wrist shift; the
// joints still), so that extrapolatePose(result, pose) goes on with that motion.
Pose poseBeforeMotion(const Pose& pose, const Pose& from, const Pose& to);

// Clamps the joint angles into their anatomical limits [l_min, l_max].
void clampToLimits(const HandModel& model, Pose* pose);

// The mean over the four fingers of MCP plus PIP flexion (radians): about 0 for an open hand,
// above 1.9 (110 degrees) for a fist. Joints the model lacks count as 0.
double meanFingerFlexion(const HandModel& model, const Pose& pose);

// E_lim of paper eq. 9: quadratic penalty outside the limits; optional gradient (joint part).
double limitPenalty(const HandModel& model, const Pose& pose, PoseVector* gradient);

}  // namespace sag_hand_tracker
