#include "sag_hand_tracker/energy/hand_projection.h"

#include "sag_hand_tracker/energy/projection.h"

namespace sag_hand_tracker {

std::vector<CameraGaussian> projectModel(const HandModel& model, const PosedHand& hand,
                                         const Camera& camera) {
  const Eigen::Matrix3d R = camera.world_to_camera.linear();
  std::vector<CameraGaussian> result(hand.gaussians.size());
  for (size_t p = 0; p < hand.gaussians.size(); ++p) {
    const Eigen::Vector3d mean = camera.world_to_camera * hand.gaussians[p].mean;
    const Eigen::Matrix3d cov = R * hand.gaussians[p].cov * R.transpose();
    result[p].depth = mean.z();
    result[p].projected = model.projection == ProjectionMode::kPerspective
                              ? projectPerspective(mean, cov, camera.K)
                              : projectScaledOrthographic(mean, cov, camera.K);
  }
  return result;
}

}  // namespace sag_hand_tracker
