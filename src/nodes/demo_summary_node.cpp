// demo_summary_node: the headless demo's report. Watches the camera sets, the tracker's outputs and
// the studio's ground truth, matches them by stamp, and after `duration` seconds (or when the
// studio has played its last sequence) prints a summary and ends the launch: with end_launch it
// sends SIGINT to its parent roslaunch, which shuts every node down as on Ctrl-C (a required node
// that simply exits makes roslaunch print "REQUIRED process [...] has died!" even on a normal end,
// so the node stays up until roslaunch stops it; required="true" remains for a real crash).
//
// Topics: in: cam<i>/camera_info (i < num_cameras: one stamp per set), joint_states, fingertips,
//   status (sag_hand_tracker/TrackingStatus), ground_truth/fingertips, studio/sequence.
// Private parameters:
//   num_cameras (5)
//   duration (60 s of wall time from the first camera set; 0 = until the studio says "done")
//   settle (1.0 s): after the end, how long to wait for the outputs of the sets still in flight
//   summary_file (""): also write the figures there, as YAML
//   sets_file (""): also write one CSV row per camera set (stamp, sequence, tracker status, late,
//     latency, the tracker's work, fingertip error), to see which sets make the latency's tail
//   end_launch (false): after the summary, SIGINT the parent process when it is roslaunch (else,
//     and 10 s after the signal if still running, the node shuts itself down)
// Sets are counted from the first one that comes when this node is connected to the tracker's
// and the studio's outputs (joint_states, fingertips, status, ground_truth/fingertips): the
// connections from this process to the nodelet manager's publishers are made after the studio
// may have started (it waits only for the segmentation nodelets), and a set published before
// them would look dropped though the tracker may have processed it (session 51: in one of three
// runs the first 55 sets, 0.9 s, had no status here). The summary says how many sets came before.
// Outputs not connected 5 s after the first set (a tracker that died) no longer hold the count
// back: its sets then count as dropped. Latency: ros::WallTime::now() when the joint state arrives
// minus its header stamp (the image stamp); meaningful with wall-clock stamps (no use_sim_time; the
// studio stamps with now()). Late joint states (the tracker's catch-up: a set first reported
// without a pose while a search ran, its status with `late`) count as joint states, so their sets
// are not dropped; their latency is in every latency figure, and also reported on its own beside
// the on-time ones', with a histogram of both.
#include <geometry_msgs/PoseArray.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/JointState.h>
#include <std_msgs/String.h>

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "sag_hand_tracker/TrackingStatus.h"

namespace {

struct SetRecord {
  int cameras = 0;
  bool status = false;
  std::string status_text;
  bool joint_state = false;
  bool late = false;  // a late status with a pose (the catch-up) came for this set
  bool fingertips = false;
  bool ground_truth = false;
  double latency = NAN;  // seconds, joint state
  double work = NAN;     // seconds the tracker spent on the set (its status; a catch-up included)
  double error = NAN;    // mean fingertip error (m) when both are there
  std::string sequence;
  std::vector<double> tips, truth;  // 15 values each
};

double percentile(std::vector<double> values, double p) {
  if (values.empty()) return NAN;
  std::sort(values.begin(), values.end());
  const double rank = p / 100.0 * (values.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(rank));
  const size_t hi = std::min(lo + 1, values.size() - 1);
  return values[lo] + (rank - lo) * (values[hi] - values[lo]);
}

double maximum(const std::vector<double>& values) {
  return values.empty() ? NAN : *std::max_element(values.begin(), values.end());
}

// Latency histogram buckets (ms): [0, 2), [2, 5), ... [200, inf).
const std::vector<double> kBucketEdges = {0, 2, 5, 10, 20, 50, 100, 200};

std::vector<long> histogram(const std::vector<double>& values) {
  std::vector<long> counts(kBucketEdges.size(), 0);
  for (double v : values) {
    size_t b = 0;
    while (b + 1 < kBucketEdges.size() && v >= kBucketEdges[b + 1]) ++b;
    ++counts[b];
  }
  return counts;
}

std::string bucketName(size_t b) {
  char name[64];
  if (b + 1 < kBucketEdges.size()) {
    std::snprintf(name, sizeof name, "[%g, %g)", kBucketEdges[b], kBucketEdges[b + 1]);
  } else {
    std::snprintf(name, sizeof name, ">= %g", kBucketEdges[b]);
  }
  return name;
}

double mean(const std::vector<double>& values) {
  if (values.empty()) return NAN;
  double sum = 0.0;
  for (double v : values) sum += v;
  return sum / values.size();
}

std::vector<double> flatten(const geometry_msgs::PoseArray& msg) {
  std::vector<double> out;
  for (const auto& pose : msg.poses) {
    out.push_back(pose.position.x);
    out.push_back(pose.position.y);
    out.push_back(pose.position.z);
  }
  return out;
}

class DemoSummary {
 public:
  DemoSummary() : pnh_("~") {
    num_cameras_ = pnh_.param("num_cameras", 5);
    duration_ = pnh_.param("duration", 60.0);
    settle_ = pnh_.param("settle", 1.0);
    end_launch_ = pnh_.param("end_launch", false);
    summary_file_ = pnh_.param<std::string>("summary_file", "");
    sets_file_ = pnh_.param<std::string>("sets_file", "");
    for (int i = 0; i < num_cameras_; ++i) {
      subs_.push_back(nh_.subscribe<sensor_msgs::CameraInfo>(
          "cam" + std::to_string(i) + "/camera_info", 20,
          [this](const sensor_msgs::CameraInfo::ConstPtr& msg) { onCameraInfo(*msg); }));
    }
    outputs_.push_back(nh_.subscribe<sensor_msgs::JointState>(
        "joint_states", 20, [this](const sensor_msgs::JointState::ConstPtr& msg) {
          const ros::WallTime now = ros::WallTime::now();
          std::lock_guard<std::mutex> lock(mutex_);
          SetRecord* set = find(msg->header.stamp);
          if (!set) return;
          set->joint_state = true;
          set->latency = now.toSec() - msg->header.stamp.toSec();
          ++joint_states_;
        }));
    outputs_.push_back(nh_.subscribe<geometry_msgs::PoseArray>(
        "fingertips", 20, [this](const geometry_msgs::PoseArray::ConstPtr& msg) {
          std::lock_guard<std::mutex> lock(mutex_);
          SetRecord* set = find(msg->header.stamp);
          if (!set) return;
          set->fingertips = true;
          set->tips = flatten(*msg);
        }));
    outputs_.push_back(nh_.subscribe<geometry_msgs::PoseArray>(
        "ground_truth/fingertips", 20, [this](const geometry_msgs::PoseArray::ConstPtr& msg) {
          std::lock_guard<std::mutex> lock(mutex_);
          SetRecord* set = find(msg->header.stamp);
          if (!set) return;
          set->ground_truth = true;
          set->truth = flatten(*msg);
          set->sequence = sequence_;
        }));
    outputs_.push_back(nh_.subscribe<sag_hand_tracker::TrackingStatus>(
        "status", 20, [this](const sag_hand_tracker::TrackingStatus::ConstPtr& msg) {
          std::lock_guard<std::mutex> lock(mutex_);
          SetRecord* set = find(msg->header.stamp);
          if (!set) return;
          if (msg->late && msg->has_pose) {
            // The set's second status: its pose, found once the search had finished. The first
            // one (without a pose) already counted the set as processed.
            set->late = true;
            ++late_statuses_;
          } else {
            set->status = true;
            set->status_text = msg->status;
            set->work = msg->seconds_per_frame;
          }
          if (msg->restarted) ++restarts_;
        }));
    subs_.push_back(nh_.subscribe<std_msgs::String>(
        "studio/sequence", 5, [this](const std_msgs::String::ConstPtr& msg) {
          std::lock_guard<std::mutex> lock(mutex_);
          if (msg->data == "done") {
            if (!ending_) {
              ending_ = true;
              end_wall_ = ros::WallTime::now();
            }
          } else {
            sequence_ = msg->data;
            if (std::find(sequences_.begin(), sequences_.end(), sequence_) == sequences_.end())
              sequences_.push_back(sequence_);
          }
        }));
    timer_ = nh_.createWallTimer(ros::WallDuration(0.1),
                                 [this](const ros::WallTimerEvent&) { onTimer(); });
    ROS_INFO("demo summary: watching %d cameras for %s", num_cameras_,
             duration_ > 0 ? (std::to_string(duration_) + " s").c_str() : "the studio's sequences");
  }

 private:
  // The record of a set (null for a stamp outside the window; outputs come after their set's
  // camera_info, so they are matched to known sets only). Caller holds mutex_.
  SetRecord* find(const ros::Time& stamp) {
    auto it = sets_.find(stamp);
    return it == sets_.end() ? nullptr : &it->second;
  }

  void onCameraInfo(const sensor_msgs::CameraInfo& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (ending_) return;  // sets after the end are not counted
    // A set that began before the count did stays uncounted, all its cameras (also those that
    // come once the count has begun).
    if (unobserved_.count(msg.header.stamp) > 0) return;
    const ros::WallTime now = ros::WallTime::now();
    if (sets_.empty()) {
      if (unobserved_.empty()) first_info_wall_ = now;
      // Not yet connected (a tracker that never comes is counted after kConnectWait: every set
      // dropped).
      if (!outputsConnected() && (now - first_info_wall_).toSec() < kConnectWait) {
        unobserved_.insert(msg.header.stamp);
        return;
      }
      first_wall_ = now;
    }
    ++sets_[msg.header.stamp].cameras;
  }

  // Whether every output topic has its publisher connected to this node.
  bool outputsConnected() const {
    for (const ros::Subscriber& output : outputs_) {
      if (output.getNumPublishers() == 0) return false;
    }
    return true;
  }

  void onTimer() {
    std::lock_guard<std::mutex> lock(mutex_);
    const ros::WallTime now = ros::WallTime::now();
    if (!ending_ && !sets_.empty() && duration_ > 0 && (now - first_wall_).toSec() >= duration_) {
      ending_ = true;
      end_wall_ = now;
    }
    if (ending_ && (now - end_wall_).toSec() >= settle_ && !reported_) {
      reported_ = true;
      report();
      if (!(end_launch_ && stopParentLaunch())) ros::shutdown();
      launch_signalled_ = now;
    }
    if (reported_ && (now - launch_signalled_).toSec() > 10.0) {
      ROS_WARN("demo_summary: roslaunch did not stop 10 s after SIGINT; ending this node");
      ros::shutdown();
    }
  }

  // SIGINT to the parent process if it is roslaunch: the launch ends as on Ctrl-C.
  static bool stopParentLaunch() {
    const pid_t parent = getppid();
    std::ifstream cmdline("/proc/" + std::to_string(parent) + "/cmdline");
    std::string text((std::istreambuf_iterator<char>(cmdline)), std::istreambuf_iterator<char>());
    if (text.find("roslaunch") == std::string::npos) return false;
    return kill(parent, SIGINT) == 0;
  }

  void report() {
    long sets = 0, complete = 0, with_status = 0, with_joints = 0, hand_sets = 0,
         hand_without_joints = 0, hand_unprocessed = 0;
    std::vector<double> latencies, on_time_latencies, late_latencies, errors, work;
    std::map<std::string, std::vector<double>> per_sequence;
    std::map<std::string, long> statuses, dropped_by_status;
    for (auto& [stamp, set] : sets_) {
      ++sets;
      if (set.cameras >= num_cameras_) ++complete;
      if (set.status) {
        if (std::isfinite(set.work)) work.push_back(set.work * 1000.0);
        ++with_status;
        ++statuses[set.status_text];
      }
      if (set.joint_state) {
        ++with_joints;
        latencies.push_back(set.latency * 1000.0);
        (set.late ? late_latencies : on_time_latencies).push_back(set.latency * 1000.0);
      }
      if (set.ground_truth) {
        ++hand_sets;
        if (!set.joint_state) {
          ++hand_without_joints;
          ++dropped_by_status[set.status ? set.status_text : "no status"];
        }
        if (!set.status) ++hand_unprocessed;
      }
      if (set.ground_truth && set.fingertips && set.tips.size() == set.truth.size() &&
          !set.tips.empty()) {
        double sum = 0.0;
        const size_t tips = set.tips.size() / 3;
        for (size_t t = 0; t < tips; ++t) {
          const double dx = set.tips[3 * t] - set.truth[3 * t];
          const double dy = set.tips[3 * t + 1] - set.truth[3 * t + 1];
          const double dz = set.tips[3 * t + 2] - set.truth[3 * t + 2];
          sum += std::sqrt(dx * dx + dy * dy + dz * dz);
        }
        set.error = sum / tips * 1000.0;
        errors.push_back(set.error);
        per_sequence[set.sequence].push_back(set.error);
      }
    }
    const double seconds = std::max(1e-9, (end_wall_ - first_wall_).toSec());
    std::ostringstream out;
    char line[512];
    out << "\n==================== sag_hand_tracker demo summary ====================\n";
    std::snprintf(line, sizeof line,
                  "run: %.1f s of wall time, %d cameras, sequences played: %zu\n", seconds,
                  num_cameras_, sequences_.size());
    out << line;
    std::snprintf(line, sizeof line,
                  "camera sets published: %ld (%ld with all %d cameras), %.2f sets/s\n", sets,
                  complete, num_cameras_, sets / seconds);
    out << line;
    if (!unobserved_.empty()) {
      std::snprintf(line, sizeof line,
                    "  before them, %zu sets came while this node was not yet connected to the "
                    "tracker's and the studio's outputs: not counted\n",
                    unobserved_.size());
      out << line;
    }
    std::snprintf(line, sizeof line,
                  "tracker: %ld sets processed (a status), %ld not (%ld with the hand in view; "
                  "the others: empty frames, e.g. the segmentation's background-plate frames); "
                  "%ld joint states, %.2f /s; restarts %ld\n",
                  with_status, sets - with_status, hand_unprocessed, with_joints,
                  with_joints / seconds, restarts_);
    out << line;
    out << "status counts:";
    for (const auto& [name, count] : statuses) out << " " << name << " " << count;
    out << "\n";
    std::snprintf(line, sizeof line,
                  "DROPPED sets (hand in view, no joint state): %ld of %ld; sets without a joint "
                  "state in all: %ld of %ld (the rest: the studio's empty frames)\n",
                  hand_without_joints, hand_sets, sets - with_joints, sets);
    out << line;
    if (!dropped_by_status.empty()) {
      out << "  dropped by the status of their set:";
      for (const auto& [name, count] : dropped_by_status) out << " " << name << " " << count;
      out << " (\"no status\": the set never reached the tracker's output)\n";
    }
    std::snprintf(line, sizeof line,
                  "fingertip error vs ground truth: mean %.1f mm, median %.1f mm, 95th pct %.1f "
                  "mm over %zu sets\n",
                  mean(errors), percentile(errors, 50), percentile(errors, 95), errors.size());
    out << line;
    for (const std::string& name : sequences_) {
      const auto it = per_sequence.find(name);
      if (it == per_sequence.end()) continue;
      std::snprintf(line, sizeof line, "  %-12s mean %.1f mm over %zu sets\n", name.c_str(),
                    mean(it->second), it->second.size());
      out << line;
    }
    std::snprintf(line, sizeof line,
                  "latency image stamp -> joint_states (all %zu, late ones included): median "
                  "%.1f ms, 99th pct %.1f ms, max %.1f ms\n",
                  latencies.size(), percentile(latencies, 50), percentile(latencies, 99),
                  maximum(latencies));
    out << line;
    std::snprintf(line, sizeof line,
                  "  on time %zu: median %.1f ms, 99th pct %.1f ms, max %.1f ms; late (catch-up) "
                  "%zu (%ld late statuses): median %.1f ms, max %.1f ms\n",
                  on_time_latencies.size(), percentile(on_time_latencies, 50),
                  percentile(on_time_latencies, 99), maximum(on_time_latencies),
                  late_latencies.size(), late_statuses_, percentile(late_latencies, 50),
                  maximum(late_latencies));
    out << line;
    std::snprintf(line, sizeof line,
                  "  the tracker's work per set (status seconds_per_frame, a catch-up included): "
                  "median %.1f ms, 99th pct %.1f ms, max %.1f ms\n",
                  percentile(work, 50), percentile(work, 99), maximum(work));
    out << line;
    const std::vector<long> on_time_histogram = histogram(on_time_latencies);
    const std::vector<long> late_histogram = histogram(late_latencies);
    out << "  latency histogram (ms)   on time     late\n";
    for (size_t b = 0; b < on_time_histogram.size(); ++b) {
      std::snprintf(line, sizeof line, "  %-22s %8ld %8ld\n", bucketName(b).c_str(),
                    on_time_histogram[b], late_histogram[b]);
      out << line;
    }
    out << "=======================================================================\n";
    std::printf("%s", out.str().c_str());
    std::fflush(stdout);
    if (!summary_file_.empty()) {
      std::ofstream file(summary_file_);
      file << "seconds: " << seconds << "\ncameras: " << num_cameras_ << "\nsets: " << sets
           << "\ncomplete_sets: " << complete
           << "\nsets_before_outputs_connected: " << unobserved_.size()
           << "\nprocessed_sets: " << with_status << "\nunprocessed_sets: " << sets - with_status
           << "\nunprocessed_sets_with_hand: " << hand_unprocessed
           << "\njoint_states: " << with_joints << "\njoint_state_rate: " << with_joints / seconds
           << "\ndropped_sets: " << hand_without_joints << "\nhand_sets: " << hand_sets
           << "\nrestarts: " << restarts_ << "\nmean_fingertip_error_mm: " << mean(errors)
           << "\nmedian_fingertip_error_mm: " << percentile(errors, 50)
           << "\nerror_sets: " << errors.size()
           << "\nlatency_median_ms: " << percentile(latencies, 50)
           << "\nlatency_p99_ms: " << percentile(latencies, 99)
           << "\nlatency_max_ms: " << maximum(latencies)
           << "\non_time_joint_states: " << on_time_latencies.size()
           << "\non_time_latency_median_ms: " << percentile(on_time_latencies, 50)
           << "\non_time_latency_p99_ms: " << percentile(on_time_latencies, 99)
           << "\non_time_latency_max_ms: " << maximum(on_time_latencies)
           << "\nlate_joint_states: " << late_latencies.size()
           << "\nlate_latency_median_ms: " << percentile(late_latencies, 50)
           << "\nlate_latency_max_ms: " << maximum(late_latencies)
           << "\ntracker_work_median_ms: " << percentile(work, 50)
           << "\ntracker_work_p99_ms: " << percentile(work, 99)
           << "\ntracker_work_max_ms: " << maximum(work) << "\nlatency_histogram_ms:\n";
      for (size_t b = 0; b < on_time_histogram.size(); ++b) {
        file << "  - {bucket: \"" << bucketName(b) << "\", on_time: " << on_time_histogram[b]
             << ", late: " << late_histogram[b] << "}\n";
      }
      if (!file) ROS_ERROR("cannot write the summary to %s", summary_file_.c_str());
    }
    if (!sets_file_.empty()) writeSets();
  }

  void writeSets() const {
    std::ofstream file(sets_file_);
    file << "stamp,sequence,cameras,status,has_joint_state,late,latency_ms,tracker_work_ms,"
            "fingertip_error_mm\n";
    char row[256];
    for (const auto& [stamp, set] : sets_) {
      std::snprintf(row, sizeof row, "%.6f,%s,%d,%s,%d,%d,%.3f,%.3f,%.2f\n", stamp.toSec(),
                    set.sequence.c_str(), set.cameras,
                    set.status ? set.status_text.c_str() : "none", set.joint_state ? 1 : 0,
                    set.late ? 1 : 0, set.latency * 1000.0, set.work * 1000.0, set.error);
      file << row;
    }
    if (!file) ROS_ERROR("cannot write the sets to %s", sets_file_.c_str());
  }

  ros::NodeHandle nh_, pnh_;
  int num_cameras_ = 5;
  double duration_ = 60.0, settle_ = 1.0;
  bool end_launch_ = false;
  ros::WallTime launch_signalled_;
  std::string summary_file_, sets_file_;
  std::vector<ros::Subscriber> subs_;
  std::vector<ros::Subscriber> outputs_;  // the tracker's and the studio's outputs
  ros::WallTimer timer_;

  std::mutex mutex_;
  std::map<ros::Time, SetRecord> sets_;
  std::set<ros::Time> unobserved_;  // sets before the outputs were connected (not counted)
  ros::WallTime first_info_wall_;   // the first camera set's arrival, counted or not
  static constexpr double kConnectWait = 5.0;  // seconds
  std::string sequence_;
  std::vector<std::string> sequences_;
  long joint_states_ = 0, restarts_ = 0, late_statuses_ = 0;
  bool ending_ = false, reported_ = false;
  ros::WallTime first_wall_, end_wall_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "demo_summary");
  DemoSummary summary;
  ros::AsyncSpinner spinner(2);
  spinner.start();
  ros::waitForShutdown();
  return 0;
}
