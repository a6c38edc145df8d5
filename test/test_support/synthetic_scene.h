// Test helpers: a ring of cameras around a tabletop workspace and image SoGs made from the model
// itself (the projected 1-sigma ellipses filled with a grid of small isotropic Gaussians).
#pragma once

#include <Eigen/Dense>
#include <random>
#include <vector>

#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/energy/energy.h"
#include "sag_hand_tracker/energy/projection.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/kinematics.h"

namespace sag_test {

using namespace sag_hand_tracker;

inline std::string modelPath(const std::string& name) {
  return resolveModelPath(name, std::string(SAG_SOURCE_DIR) + "/config");
}

// A camera at `eye` looking at `target` (optical frame: z forward, y down, x right).
inline Camera lookAtCamera(const std::string& name, const Eigen::Vector3d& eye,
                           const Eigen::Vector3d& target, int width = 320, int height = 240,
                           double focal = 300.0) {
  Camera camera;
  camera.name = name;
  camera.width = width;
  camera.height = height;
  camera.K << focal, 0.0, width / 2.0, 0.0, focal, height / 2.0, 0.0, 0.0, 1.0;
  const Eigen::Vector3d z = (target - eye).normalized();
  Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ());
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitX();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d camera_to_world;
  camera_to_world << x, y, z;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = camera_to_world;
  pose.translation() = eye;
  camera.world_to_camera = pose.inverse();
  return camera;
}

// Five cameras around the workspace centre (0, 0, 0.15), like a Dexter-1-style studio.
inline std::vector<Camera> fiveCameraRig() {
  const Eigen::Vector3d centre(0.0, 0.0, 0.15);
  std::vector<Camera> cameras;
  const double azimuths[5] = {0.0, 72.0, 144.0, 216.0, 288.0};
  const double heights[5] = {0.55, 0.35, 0.65, 0.40, 0.50};
  for (int i = 0; i < 5; ++i) {
    const double a = azimuths[i] * M_PI / 180.0;
    const Eigen::Vector3d eye =
        centre + Eigen::Vector3d(0.6 * std::cos(a), 0.6 * std::sin(a), heights[i]);
    cameras.push_back(lookAtCamera("cam" + std::to_string(i), eye, centre));
  }
  return cameras;
}

// A pose of the hand in the workspace: palm facing down, fingers along +x, joints mid-range.
inline Pose typicalPose(const HandModel& model) {
  Pose pose = neutralPose(model, Eigen::Vector3d(-0.06, 0.0, 0.15), Eigen::Matrix3d::Identity());
  for (int j = 0; j < kNumJointDof; ++j) {
    pose.joints[j] = model.joints[j].min + 0.3 * (model.joints[j].max - model.joints[j].min);
  }
  return pose;
}

// Image SoG of the model itself: a grid of isotropic Gaussians (spacing `cell` px, sigma cell/2)
// covering the union of the projected 1-sigma ellipses, coloured like the covering Gaussian.
inline ImageSoG modelImageSoG(const HandModel& model, const Pose& pose, const Camera& camera,
                              double cell = 4.0) {
  const PosedHand hand = forwardKinematics(model, pose);
  std::vector<ProjectedGaussian> projected;
  for (const WorldGaussian& g : hand.gaussians) {
    const Eigen::Vector3d mean = camera.world_to_camera * g.mean;
    const Eigen::Matrix3d R = camera.world_to_camera.linear();
    projected.push_back(model.projection == ProjectionMode::kPerspective
                            ? projectPerspective(mean, R * g.cov * R.transpose(), camera.K)
                            : projectScaledOrthographic(mean, R * g.cov * R.transpose(), camera.K));
  }
  ImageSoG sog;
  sog.width = camera.width;
  sog.height = camera.height;
  for (double y = cell / 2; y < camera.height; y += cell) {
    for (double x = cell / 2; x < camera.width; x += cell) {
      const Eigen::Vector2d pixel(x, y);
      for (size_t p = 0; p < projected.size(); ++p) {
        if (!projected[p].valid) continue;
        const Eigen::Vector2d d = pixel - projected[p].mean;
        if (d.dot(projected[p].cov.inverse() * d) <= 1.0) {
          sog.gaussians.push_back({pixel, cell / 2.0, model.gaussians[p].hsv});
          break;
        }
      }
    }
  }
  return sog;
}

// The model with a bare forearm (issue 9) for model-made images: the energy's forearm
// (EnergyParams::forearm_*) as Gaussians of the palm bone, along `direction` (palm frame, from the
// wrist; the default: straight on from the palm), in the palm's colour.
inline HandModel withForearm(const HandModel& model, const EnergyParams& params,
                             const Eigen::Vector3d& direction = -Eigen::Vector3d::UnitX()) {
  HandModel scene = model;
  const ForearmGaussians forearm =
      forearmGaussians(params, Eigen::Vector3d::Zero(), direction.normalized());
  for (const Eigen::Vector3d& mean : forearm.means) {
    ModelGaussian arm = model.gaussians.front();
    arm.bone = 0;
    arm.mean = mean;
    arm.cov = forearm.cov;
    scene.gaussians.push_back(arm);
  }
  return scene;
}

inline std::vector<CameraObservation> modelObservations(const HandModel& model, const Pose& pose,
                                                        const std::vector<Camera>& cameras,
                                                        double cell = 4.0) {
  std::vector<CameraObservation> observations;
  for (const Camera& camera : cameras) {
    observations.push_back({camera, modelImageSoG(model, pose, camera, cell)});
  }
  return observations;
}

}  // namespace sag_test
