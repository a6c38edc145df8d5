// Shared by the graph tests' checkers (fingertip_checker, foreground_checker): renders the studio
// bag a rostest replays, once the checker's subscribers are up. rostest launches the graph anew for
// every <test>, so each checker prepares the bag it listens to.
// Private parameters: prepare_bag (sequence name, "" = none), frames (40), render_args (extra
// render_bag arguments, e.g. "--room office --hand-masks"), bag, ready_file (created last: the
// player waits for it), csv and track_args (optional: track_bag on the bag first, e.g.
// "--background-frames 0 --room-cues").
#pragma once

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace graph_test {

inline std::string binDir() {
  return std::filesystem::read_symlink("/proc/self/exe").parent_path().string();
}

inline int run(const std::string& command) {
  ROS_INFO("%s", command.c_str());
  return std::system(command.c_str());
}

// Call with ASSERT_NO_FATAL_FAILURE.
inline void prepareBag() {
  ros::NodeHandle pnh("~");
  const std::string sequence = pnh.param<std::string>("prepare_bag", "");
  if (sequence.empty()) return;
  const std::string bag = pnh.param<std::string>("bag", "");
  const std::string ready = pnh.param<std::string>("ready_file", "");
  const std::string csv = pnh.param<std::string>("csv", "");
  ASSERT_FALSE(bag.empty()) << "~bag is required with ~prepare_bag";
  ASSERT_FALSE(ready.empty()) << "~ready_file is required with ~prepare_bag";
  std::filesystem::remove(ready);
  std::filesystem::create_directories(std::filesystem::path(bag).parent_path());
  const std::string frames = std::to_string(pnh.param("frames", 40));
  const std::string render_args = pnh.param<std::string>("render_args", "");
  const std::string track_args = pnh.param<std::string>("track_args", "");
  ASSERT_EQ(run(binDir() + "/render_bag --quiet --sequence " + sequence + " --frames " + frames +
                " " + render_args + " --overwrite --out " + bag),
            0);
  if (!csv.empty()) {
    std::filesystem::remove(csv);
    ASSERT_EQ(
        run(binDir() + "/track_bag --quiet --bag " + bag + " " + track_args + " --out " + csv), 0);
  }
  std::ofstream(ready) << "ready\n";
}

// Removes this launch's ready file (the player has started from it), so that none piles up.
inline void removeReadyFile() {
  const std::string ready = ros::NodeHandle("~").param<std::string>("ready_file", "");
  if (!ready.empty()) std::filesystem::remove(ready);
}

// Removes the ready file when the checker's test ends (however it ends).
struct ReadyFileRemover {
  ~ReadyFileRemover() { removeReadyFile(); }
};

}  // namespace graph_test
