// gtest checker of the graph's fingertips (rostest helper) against a reference, matched by stamp:
//   - reference "ground_truth": the studio's ground_truth/fingertips topic (demo_graph.test);
//     asserts enough matched sets and a mean fingertip error under max_mean_error;
//   - reference "csv": track_bag's CSV on the same bag (replay_bag.test); with prepare_bag set,
//     the checker first renders that bag with render_bag and tracks it with track_bag (the
//     binaries next to this one), then creates ready_file so that the player (launched with a
//     prefix that waits for it) starts; asserts that most CSV rows are matched by the graph and
//     that the matched fingertips agree within max_mean_difference / max_difference.
// Private parameters: reference (ground_truth|csv), duration (s, wall), idle_timeout (s: stop
//   early when fingertips stopped coming for this long after some arrived; 0 = never),
//   min_matched, max_mean_error (m), csv, prepare_bag (sequence name, "" = none), bag,
//   frames, ready_file, min_matched_fraction, max_mean_difference (m), max_difference (m).
#include <geometry_msgs/PoseArray.h>
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "sag_hand_tracker/apps/csv.h"

namespace {

using Tips = std::array<Eigen::Vector3d, 5>;

Tips toTips(const geometry_msgs::PoseArray& msg) {
  Tips tips;
  for (size_t i = 0; i < 5 && i < msg.poses.size(); ++i) {
    tips[i] =
        Eigen::Vector3d(msg.poses[i].position.x, msg.poses[i].position.y, msg.poses[i].position.z);
  }
  return tips;
}

double meanDistance(const Tips& a, const Tips& b) {
  double sum = 0.0;
  for (size_t i = 0; i < 5; ++i) sum += (a[i] - b[i]).norm();
  return sum / 5.0;
}

// Stamps rounded to microseconds (the CSV holds 6 decimals).
long long key(double seconds) { return std::llround(seconds * 1e6); }

std::string binDir() {
  return std::filesystem::read_symlink("/proc/self/exe").parent_path().string();
}

int run(const std::string& command) {
  ROS_INFO("fingertip_checker: %s", command.c_str());
  return std::system(command.c_str());
}

class FingertipChecker : public ::testing::Test {
 protected:
  void collect(bool with_ground_truth) {
    ros::NodeHandle nh, pnh("~");
    const double duration = pnh.param("duration", 15.0);
    const double idle_timeout = pnh.param("idle_timeout", 0.0);
    ros::Subscriber tips_sub = nh.subscribe<geometry_msgs::PoseArray>(
        "fingertips", 50, [this](const geometry_msgs::PoseArray::ConstPtr& msg) {
          std::lock_guard<std::mutex> lock(mutex_);
          if (msg->poses.size() != 5) {
            ++malformed_;
            return;
          }
          tracked_[key(msg->header.stamp.toSec())] = toTips(*msg);
          last_arrival_ = ros::WallTime::now();
        });
    ros::Subscriber truth_sub;
    if (with_ground_truth) {
      truth_sub = nh.subscribe<geometry_msgs::PoseArray>(
          "ground_truth/fingertips", 50, [this](const geometry_msgs::PoseArray::ConstPtr& msg) {
            std::lock_guard<std::mutex> lock(mutex_);
            if (msg->poses.size() == 5) reference_[key(msg->header.stamp.toSec())] = toTips(*msg);
          });
    }
    const ros::WallTime start = ros::WallTime::now();
    while (ros::ok() && (ros::WallTime::now() - start).toSec() < duration) {
      ros::WallDuration(0.1).sleep();
      std::lock_guard<std::mutex> lock(mutex_);
      if (idle_timeout > 0 && !tracked_.empty() &&
          (ros::WallTime::now() - last_arrival_).toSec() > idle_timeout) {
        ROS_INFO("fingertip_checker: no fingertips for %.1f s, done", idle_timeout);
        break;
      }
    }
  }

  std::mutex mutex_;
  std::map<long long, Tips> tracked_, reference_;
  ros::WallTime last_arrival_;
  int malformed_ = 0;
};

TEST_F(FingertipChecker, AgainstReference) {
  ros::NodeHandle pnh("~");
  const std::string reference = pnh.param<std::string>("reference", "ground_truth");
  ros::AsyncSpinner spinner(1);
  spinner.start();

  if (reference == "ground_truth") {
    collect(true);
    std::vector<double> errors;
    for (const auto& [stamp, tips] : tracked_) {
      const auto it = reference_.find(stamp);
      if (it != reference_.end()) errors.push_back(meanDistance(tips, it->second));
    }
    double mean = 0.0;
    for (double e : errors) mean += e;
    mean /= std::max<size_t>(1, errors.size());
    std::printf(
        "fingertip_checker: %zu tracked sets, %zu ground-truth sets, %zu matched, mean "
        "fingertip error %.2f mm\n",
        tracked_.size(), reference_.size(), errors.size(), mean * 1000.0);
    EXPECT_EQ(malformed_, 0);
    EXPECT_GE(static_cast<int>(errors.size()), pnh.param("min_matched", 100));
    EXPECT_LT(mean, pnh.param("max_mean_error", 0.02));
    return;
  }

  ASSERT_EQ(reference, "csv");
  const std::string csv = pnh.param<std::string>("csv", "");
  ASSERT_FALSE(csv.empty()) << "~csv is required";
  const std::string sequence = pnh.param<std::string>("prepare_bag", "");
  if (!sequence.empty()) {
    const std::string bag = pnh.param<std::string>("bag", "");
    const std::string ready = pnh.param<std::string>("ready_file", "");
    ASSERT_FALSE(bag.empty());
    ASSERT_FALSE(ready.empty());
    std::filesystem::remove(ready);
    std::filesystem::create_directories(std::filesystem::path(bag).parent_path());
    const std::string frames = std::to_string(pnh.param("frames", 40));
    ASSERT_EQ(run(binDir() + "/render_bag --quiet --sequence " + sequence + " --frames " + frames +
                  " --out " + bag),
              0);
    ASSERT_EQ(run(binDir() + "/track_bag --quiet --bag " + bag + " --out " + csv), 0);
    std::ofstream(ready) << "ready\n";
  }
  collect(false);
  const sag_hand_tracker::TrackingCsv offline = sag_hand_tracker::readTrackingCsv(csv);
  ASSERT_FALSE(offline.rows.empty());
  int matched = 0;
  double sum = 0.0, worst = 0.0;
  for (const auto& row : offline.rows) {
    const auto it = tracked_.find(key(row.stamp));
    if (it == tracked_.end()) continue;
    Tips tips;
    for (size_t i = 0; i < 5; ++i) tips[i] = row.fingertips[i];
    const double d = meanDistance(tips, it->second);
    ++matched;
    sum += d;
    worst = std::max(worst, d);
  }
  const double fraction = static_cast<double>(matched) / offline.rows.size();
  const double mean = sum / std::max(1, matched);
  std::printf(
      "fingertip_checker: track_bag %zu rows, graph %zu fingertip sets, %d matched "
      "(%.0f%%), mean difference %.3f mm, max %.3f mm\n",
      offline.rows.size(), tracked_.size(), matched, 100.0 * fraction, mean * 1000.0,
      worst * 1000.0);
  EXPECT_EQ(malformed_, 0);
  EXPECT_GE(fraction, pnh.param("min_matched_fraction", 0.8));
  EXPECT_LT(mean, pnh.param("max_mean_difference", 0.002));
  EXPECT_LT(worst, pnh.param("max_difference", 0.01));
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "fingertip_checker");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
