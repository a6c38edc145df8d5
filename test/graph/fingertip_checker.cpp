// gtest checker of the graph's fingertips (rostest helper) against a reference, matched by stamp:
//   - reference "ground_truth": the studio's or the bag's ground_truth/fingertips topic
//     (demo_graph.test, room_graph.test); asserts enough matched sets and a mean fingertip error
//     under max_mean_error; with prepare_bag the bag is rendered first (below) and, with csv,
//     track_bag's error on it against the same ground truth is printed next to the graph's;
//   - reference "csv": track_bag's CSV on the same bag (replay_bag.test); with prepare_bag set,
//     the checker first renders that bag with render_bag and tracks it with track_bag (the
//     binaries next to this one), then creates ready_file so that the player (launched with a
//     prefix that waits for it) starts; asserts that most CSV rows are matched by the graph and
//     that the matched fingertips agree within max_mean_difference / max_difference.
// Private parameters: reference (ground_truth|csv), duration (s, wall), idle_timeout (s: stop
//   early when fingertips stopped coming for this long after some arrived; 0 = never),
//   min_matched, max_mean_error (m), csv, prepare_bag (sequence name, "" = none), bag,
//   frames, ready_file, min_matched_fraction, max_mean_difference (m), max_difference (m),
//   render_args and track_args (extra arguments of render_bag and track_bag, e.g.
//   "--room office --hand-masks" and "--background-frames 0 --room-cues").
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

#include "prepare_bag.h"
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
    // The bag is prepared (and the player released) only once the subscribers are up.
    ASSERT_NO_FATAL_FAILURE(graph_test::prepareBag());
    graph_test::ReadyFileRemover remove_ready_file;
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
    if (HasFatalFailure()) return;
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
    const std::string csv = pnh.param<std::string>("csv", "");
    if (!csv.empty()) {
      // track_bag on the same bag, against the same ground truth (a measurement, not a check).
      double offline_sum = 0.0;
      int offline_matched = 0;
      for (const auto& row : sag_hand_tracker::readTrackingCsv(csv).rows) {
        const auto it = reference_.find(key(row.stamp));
        if (it == reference_.end() || !row.fingertips[0].allFinite()) continue;
        Tips tips;
        for (size_t i = 0; i < 5; ++i) tips[i] = row.fingertips[i];
        offline_sum += meanDistance(tips, it->second);
        ++offline_matched;
      }
      std::printf(
          "fingertip_checker: track_bag on the same bag: %d sets matched, mean error %.2f mm\n",
          offline_matched, offline_matched ? 1000.0 * offline_sum / offline_matched : 0.0);
    }
    EXPECT_EQ(malformed_, 0);
    EXPECT_GE(static_cast<int>(errors.size()), pnh.param("min_matched", 100));
    EXPECT_LT(mean, pnh.param("max_mean_error", 0.02));
    return;
  }

  ASSERT_EQ(reference, "csv");
  const std::string csv = pnh.param<std::string>("csv", "");
  ASSERT_FALSE(csv.empty()) << "~csv is required";
  collect(false);
  if (HasFatalFailure()) return;
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
