#include "sag_hand_tracker/model/kinematics.h"

#include <cmath>

namespace sag_hand_tracker {

PosedHand forwardKinematics(const HandModel& model, const Pose& pose) {
  PosedHand hand;
  const size_t num_bones = model.bones.size();
  hand.bone_frames.resize(num_bones);

  // Root: translation along the world axes; orientation perturbed in the tangent space
  // (exp([delta]) R), i.e. about the world axes through the wrist.
  for (int i = 0; i < 3; ++i) {
    hand.dof_axis[kRootTranslation + i] = Eigen::Vector3d::Unit(i);
    hand.dof_pivot[kRootTranslation + i] = pose.translation;
    hand.dof_axis[kRootRotation + i] = Eigen::Vector3d::Unit(i);
    hand.dof_pivot[kRootRotation + i] = pose.translation;
  }

  for (size_t b = 0; b < num_bones; ++b) {
    const Bone& bone = model.bones[b];
    Eigen::Isometry3d frame = Eigen::Isometry3d::Identity();
    if (bone.parent < 0) {
      frame.linear() = pose.rotation;
      frame.translation() = pose.translation;
    } else {
      frame = hand.bone_frames[bone.parent];
      frame.translate(bone.offset);
    }
    frame.linear() = frame.linear() * bone.rest_rotation;
    for (int dof : bone.joint_dofs) {
      const Eigen::Vector3d& axis = model.joints[dof].axis;
      hand.dof_axis[kFirstJointDof + dof] = frame.linear() * axis;
      hand.dof_pivot[kFirstJointDof + dof] = frame.translation();
      frame.linear() =
          frame.linear() * Eigen::AngleAxisd(pose.joints[dof], axis).toRotationMatrix();
    }
    hand.bone_frames[b] = frame;
  }

  hand.gaussians.resize(model.gaussians.size());
  for (size_t g = 0; g < model.gaussians.size(); ++g) {
    const ModelGaussian& gaussian = model.gaussians[g];
    const Eigen::Isometry3d& frame = hand.bone_frames[gaussian.bone];
    hand.gaussians[g].mean = frame * gaussian.mean;
    hand.gaussians[g].cov = frame.linear() * gaussian.cov * frame.linear().transpose();
  }
  return hand;
}

Fingertips fingertips(const HandModel& model, const PosedHand& hand) {
  Fingertips tips;
  for (int finger = 0; finger < kNumFingers; ++finger) {
    const int g = model.fingertip_gaussians[finger];
    const WorldGaussian& gaussian = hand.gaussians[g];
    const Eigen::Vector3d axis = hand.bone_frames[model.gaussians[g].bone].linear().col(0);
    // Where the ray from the mean along the bone axis leaves the 1-sigma ellipsoid.
    const double inverse_extent = std::sqrt(axis.dot(gaussian.cov.ldlt().solve(axis)));
    tips[finger] = gaussian.mean + axis / inverse_extent;
  }
  return tips;
}

Fingertips fingertips(const HandModel& model, const Pose& pose) {
  return fingertips(model, forwardKinematics(model, pose));
}

Pose neutralPose(const HandModel& model, const Eigen::Vector3d& translation,
                 const Eigen::Matrix3d& rotation) {
  Pose pose;
  pose.translation = translation;
  pose.rotation = rotation;
  pose.joints.setZero();
  clampToLimits(model, &pose);
  return pose;
}

}  // namespace sag_hand_tracker
