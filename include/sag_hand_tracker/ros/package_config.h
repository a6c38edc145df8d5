// Where the package's built-in data lives (hand models, rigs, motions): one lookup for the tools
// and the nodelets.
#pragma once

#include <string>

namespace sag_hand_tracker {

// `config_dir` when it is not empty, else the installed package's config/ folder (found through
// ROS_PACKAGE_PATH). Throws InputError when the package cannot be found, saying how to fix it.
std::string packageConfigDir(const std::string& config_dir = "");

}  // namespace sag_hand_tracker
