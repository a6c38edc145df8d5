// Test support for the studio tests: a minimal reader of the rig files in config/rigs/ (the rig
// format of calibration.h), so that the studio tests do not depend on the full calibration loader.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Geometry>
#include <stdexcept>
#include <string>
#include <vector>

#include "sag_hand_tracker/camera.h"

namespace studio_test {

inline std::vector<sag_hand_tracker::Camera> readRig(const std::string& rig_path) {
  const std::string dir = rig_path.substr(0, rig_path.find_last_of('/') + 1);
  const YAML::Node rig = YAML::LoadFile(rig_path);
  std::vector<sag_hand_tracker::Camera> cameras;
  for (const YAML::Node& entry : rig["cameras"]) {
    const YAML::Node calib = YAML::LoadFile(dir + entry["calibration"].as<std::string>());
    sag_hand_tracker::Camera camera;
    camera.name = entry["name"].as<std::string>();
    camera.width = calib["image_width"].as<int>();
    camera.height = calib["image_height"].as<int>();
    const auto k = calib["camera_matrix"]["data"].as<std::vector<double>>();
    if (k.size() != 9) throw std::runtime_error("bad camera_matrix in " + rig_path);
    for (int i = 0; i < 9; ++i) camera.K(i / 3, i % 3) = k[i];
    const auto t = entry["translation"].as<std::vector<double>>();
    const auto q = entry["rotation"].as<std::vector<double>>();
    Eigen::Isometry3d camera_to_world = Eigen::Isometry3d::Identity();
    camera_to_world.linear() =
        Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized().toRotationMatrix();
    camera_to_world.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
    camera.world_to_camera = camera_to_world.inverse();
    cameras.push_back(camera);
  }
  return cameras;
}

}  // namespace studio_test
