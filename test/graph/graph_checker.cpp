// gtest node of the graph rostests: listens to the tracker's outputs for `duration` seconds and
// checks them. Private parameters (all optional):
//   duration (s, 20), min_joint_states (20): joint_states messages expected in that time
//   max_fingertip_error (m, 0 = not checked): mean distance to ground_truth/fingertips, matched
//     by stamp, over the second half of the run
//   check_after (s, 0) with min_joint_states_after (0) and expect_cameras_after (-1 = any): after
//     this time (counted from the first joint_states) that many joint_states must still arrive,
//     and the last status must report that many cameras
//   expect_warnings (list of strings): each must appear in a WARN (or worse) /rosout message
#include <geometry_msgs/PoseArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/JointState.h>

#include <cmath>
#include <map>
#include <mutex>

#include "sag_hand_tracker/TrackingStatus.h"

namespace {

struct Recorder {
  std::mutex mutex;
  std::vector<sensor_msgs::JointState> joint_states;
  std::vector<ros::WallTime> joint_arrival;
  std::map<ros::Time, geometry_msgs::PoseArray> truth;
  std::vector<geometry_msgs::PoseArray> tips;
  std::vector<sag_hand_tracker::TrackingStatus> statuses;
  std::vector<std::string> warnings;
};

TEST(TrackerGraph, OutputsAreFiniteAndKeepComing) {
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  const double duration = pnh.param("duration", 20.0);
  const int min_joint_states = pnh.param("min_joint_states", 20);
  const double max_tip_error = pnh.param("max_fingertip_error", 0.0);
  const double check_after = pnh.param("check_after", 0.0);
  const int min_after = pnh.param("min_joint_states_after", 0);
  const int expect_cameras_after = pnh.param("expect_cameras_after", -1);
  std::vector<std::string> expect_warnings;
  pnh.getParam("expect_warnings", expect_warnings);

  Recorder rec;
  auto js_sub = nh.subscribe<sensor_msgs::JointState>(
      "joint_states", 100, [&](const sensor_msgs::JointState::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(rec.mutex);
        rec.joint_states.push_back(*m);
        rec.joint_arrival.push_back(ros::WallTime::now());
      });
  auto truth_sub = nh.subscribe<geometry_msgs::PoseArray>(
      "ground_truth/fingertips", 100, [&](const geometry_msgs::PoseArray::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(rec.mutex);
        rec.truth[m->header.stamp] = *m;
      });
  auto tip_sub = nh.subscribe<geometry_msgs::PoseArray>(
      "fingertips", 100, [&](const geometry_msgs::PoseArray::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(rec.mutex);
        rec.tips.push_back(*m);
      });
  auto status_sub = nh.subscribe<sag_hand_tracker::TrackingStatus>(
      "status", 100, [&](const sag_hand_tracker::TrackingStatus::ConstPtr& m) {
        std::lock_guard<std::mutex> lock(rec.mutex);
        rec.statuses.push_back(*m);
      });
  auto log_sub =
      nh.subscribe<rosgraph_msgs::Log>("/rosout", 1000, [&](const rosgraph_msgs::Log::ConstPtr& m) {
        if (m->level < rosgraph_msgs::Log::WARN) return;
        std::lock_guard<std::mutex> lock(rec.mutex);
        rec.warnings.push_back(m->msg);
      });

  ros::AsyncSpinner spinner(2);
  spinner.start();
  ros::WallDuration(duration).sleep();
  spinner.stop();
  std::lock_guard<std::mutex> lock(rec.mutex);

  ASSERT_GE(static_cast<int>(rec.joint_states.size()), min_joint_states);
  for (const auto& js : rec.joint_states) {
    ASSERT_EQ(js.name.size(), 26u);
    ASSERT_EQ(js.position.size(), 26u);
    EXPECT_FALSE(js.header.stamp.isZero());
    for (double v : js.position) ASSERT_TRUE(std::isfinite(v)) << "non-finite joint state";
  }
  for (const auto& tips : rec.tips) {
    ASSERT_EQ(tips.poses.size(), 5u);
    for (const auto& p : tips.poses) {
      ASSERT_TRUE(std::isfinite(p.position.x) && std::isfinite(p.position.y) &&
                  std::isfinite(p.position.z));
    }
  }
  for (const auto& s : rec.statuses) {
    ASSERT_TRUE(std::isfinite(s.energy) && std::isfinite(s.similarity));
  }
  // Stamps are the image stamps: increasing.
  for (size_t k = 1; k < rec.joint_states.size(); ++k) {
    EXPECT_GT(rec.joint_states[k].header.stamp, rec.joint_states[k - 1].header.stamp);
  }

  if (max_tip_error > 0.0) {
    double sum = 0.0;
    int count = 0;
    const ros::Time half =
        rec.tips.empty() ? ros::Time()
                         : rec.tips.front().header.stamp +
                               (rec.tips.back().header.stamp - rec.tips.front().header.stamp) * 0.5;
    for (const auto& tips : rec.tips) {
      if (tips.header.stamp < half) continue;
      auto it = rec.truth.find(tips.header.stamp);
      if (it == rec.truth.end()) continue;
      for (size_t f = 0; f < 5; ++f) {
        const auto& a = tips.poses[f].position;
        const auto& b = it->second.poses[f].position;
        sum += std::sqrt((a.x - b.x) * (a.x - b.x) + (a.y - b.y) * (a.y - b.y) +
                         (a.z - b.z) * (a.z - b.z));
        ++count;
      }
    }
    ASSERT_GT(count, 0) << "no fingertips matched the ground truth by stamp";
    const double mean = sum / count;
    std::printf("mean fingertip error over the second half: %.4f m (%d tips)\n", mean, count);
    EXPECT_LT(mean, max_tip_error);
  }

  if (check_after > 0.0) {
    ASSERT_FALSE(rec.joint_arrival.empty());
    const ros::WallTime after = rec.joint_arrival.front() + ros::WallDuration(check_after);
    int count = 0;
    for (const auto& t : rec.joint_arrival) count += t > after ? 1 : 0;
    EXPECT_GE(count, min_after) << "joint_states stopped after the cameras dropped";
    if (expect_cameras_after >= 0) {
      ASSERT_FALSE(rec.statuses.empty());
      EXPECT_EQ(rec.statuses.back().num_cameras, expect_cameras_after);
      EXPECT_TRUE(rec.statuses.back().has_pose);
    }
  }

  for (const std::string& expected : expect_warnings) {
    bool found = false;
    for (const std::string& w : rec.warnings)
      found = found || w.find(expected) != std::string::npos;
    EXPECT_TRUE(found) << "no WARN on /rosout containing '" << expected << "'";
  }
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "graph_checker");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
