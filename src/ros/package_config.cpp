#include "sag_hand_tracker/ros/package_config.h"

#include <ros/package.h>

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

std::string packageConfigDir(const std::string& config_dir) {
  if (!config_dir.empty()) return config_dir;
  const std::string package = ros::package::getPath("sag_hand_tracker");
  if (package.empty()) {
    throw InputError(
        "cannot find the package sag_hand_tracker for its built-in models, rigs and motions: "
        "source devel/setup.bash, or give the config folder (--config-dir DIR, or a model file)");
  }
  return package + "/config";
}

}  // namespace sag_hand_tracker
