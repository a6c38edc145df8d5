#include "sag_hand_tracker/model/pose.h"

#include <algorithm>
#include <cmath>

namespace sag_hand_tracker {

Eigen::Matrix3d rotationFromVector(const Eigen::Vector3d& rotation_vector) {
  const double angle = rotation_vector.norm();
  if (angle < 1e-12) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, rotation_vector / angle).toRotationMatrix();
}

Eigen::Vector3d rotationToVector(const Eigen::Matrix3d& rotation) {
  const Eigen::AngleAxisd angle_axis(rotation);
  return angle_axis.angle() * angle_axis.axis();
}

PoseVector Pose::toVector() const {
  PoseVector v;
  v.segment<3>(kRootTranslation) = translation;
  v.segment<3>(kRootRotation) = rotationToVector(rotation);
  v.segment<kNumJointDof>(kFirstJointDof) = joints;
  return v;
}

Pose Pose::fromVector(const PoseVector& v) {
  Pose pose;
  pose.translation = v.segment<3>(kRootTranslation);
  pose.rotation = rotationFromVector(v.segment<3>(kRootRotation));
  pose.joints = v.segment<kNumJointDof>(kFirstJointDof);
  return pose;
}

Pose Pose::stepped(const PoseVector& step) const {
  Pose result = *this;
  result.translation += step.segment<3>(kRootTranslation);
  result.rotation = rotationFromVector(step.segment<3>(kRootRotation)) * rotation;
  // Re-orthonormalise so that rounding does not accumulate over a long track.
  const Eigen::Quaterniond q(result.rotation);
  result.rotation = q.normalized().toRotationMatrix();
  result.joints += step.segment<kNumJointDof>(kFirstJointDof);
  return result;
}

bool Pose::allFinite() const {
  return translation.allFinite() && rotation.allFinite() && joints.allFinite();
}

Pose extrapolatePose(const Pose& previous, const Pose& current) {
  Pose predicted = current;
  predicted.translation = 2.0 * current.translation - previous.translation;
  predicted.rotation = (current.rotation * previous.rotation.transpose()) * current.rotation;
  predicted.rotation = Eigen::Quaterniond(predicted.rotation).normalized().toRotationMatrix();
  predicted.joints = 2.0 * current.joints - previous.joints;
  return predicted;
}

Pose poseBeforeMotion(const Pose& pose, const Pose& from, const Pose& to) {
  Pose before = pose;
  before.translation = pose.translation - (to.translation - from.translation);
  before.rotation = (to.rotation * from.rotation.transpose()).transpose() * pose.rotation;
  before.rotation = Eigen::Quaterniond(before.rotation).normalized().toRotationMatrix();
  return before;
}

double meanFingerFlexion(const HandModel& model, const Pose& pose) {
  double sum = 0.0;
  for (const LongFingerJoints& finger : longFingerJoints(model)) {
    for (const int j : {finger.mcp_flex, finger.pip_flex}) {
      if (j >= 0 && j < kNumJointDof) sum += pose.joints[j];
    }
  }
  return sum / 4.0;
}

void clampToLimits(const HandModel& model, Pose* pose) {
  for (int j = 0; j < kNumJointDof; ++j) {
    pose->joints[j] = std::clamp(pose->joints[j], model.joints[j].min, model.joints[j].max);
  }
}

double limitPenalty(const HandModel& model, const Pose& pose, PoseVector* gradient) {
  double penalty = 0.0;
  if (gradient) gradient->setZero();
  for (int j = 0; j < kNumJointDof; ++j) {
    const double angle = pose.joints[j];
    double excess = 0.0;
    if (angle < model.joints[j].min) excess = angle - model.joints[j].min;
    if (angle > model.joints[j].max) excess = angle - model.joints[j].max;
    penalty += excess * excess;
    if (gradient) (*gradient)[kFirstJointDof + j] = 2.0 * excess;
  }
  return penalty;
}

}  // namespace sag_hand_tracker
