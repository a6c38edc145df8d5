// gtest checker of the segmentation's foreground in the graph (rostest helper; room_graph.test):
// listens to every camera's cam<i>/foreground (the segmentation's kept pixels), cam<i>/sog (the
// region it was segmented with) and the bag's cam<i>/hand_mask (render_bag --hand-masks: 255 on
// the tracked hand's pixels), matched by stamp, and measures the foreground precision and recall
// as the benchmark's rooms do (pixels kept that belong to the hand; hand pixels kept), over the
// images with the hand. For the images segmented inside the tracked hand's region it also projects
// that region (the cam<i>/hand_region the SoG names, with cam<i>/camera_info: trackedRegionMask)
// and counts the kept cells whose centre lies outside it: the segmentation must keep none.
// Private parameters: num_cameras (5), duration (s, wall, 60), idle_timeout (s: stop early when
//   no foreground arrived for this long after some did; 0 = never), min_images (images with the
//   hand segmented inside the tracked hand's region, SoG region TRACKED), min_precision (over
//   those images), cell_size (4: the segmentation's), and prepare_bag.h's (the bag is rendered once
//   the subscribers are up).
// Prints the precision over all images with the hand and over those segmented inside the tracked
// hand's region.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "prepare_bag.h"
#include "sag_hand_tracker/SumOfGaussians.h"
#include "sag_hand_tracker/ros/conversions.h"
#include "sag_hand_tracker/ros/live_room_cues.h"

namespace {

using sag_hand_tracker::SumOfGaussians;

struct Counts {
  long long kept = 0, kept_hand = 0, hand = 0;
  int images = 0;
  double precision() const { return kept > 0 ? static_cast<double>(kept_hand) / kept : 0.0; }
  double recall() const { return hand > 0 ? static_cast<double>(kept_hand) / hand : 0.0; }
};

class ForegroundChecker : public ::testing::Test {
 protected:
  struct Camera {
    std::map<long long, SumOfGaussians::ConstPtr> sogs;
    std::map<long long, sensor_msgs::Image::ConstPtr> foregrounds, masks;
    std::map<long long, sag_hand_tracker::HandRegion::ConstPtr> hand_regions;  // by their stamp
    sensor_msgs::CameraInfo::ConstPtr info;
  };

  static long long key(const ros::Time& stamp) { return static_cast<long long>(stamp.toNSec()); }

  // Adds one matched image to the counts (of its region).
  void count(const Camera& camera, const SumOfGaussians& sog, const sensor_msgs::Image& foreground,
             const sensor_msgs::Image& mask) {
    const int region = sog.region;
    if (mask.encoding != "mono8" || foreground.encoding != "mono8" ||
        mask.width != foreground.width || mask.height != foreground.height) {
      ++mismatched_;
      return;
    }
    Counts frame;
    frame.images = 1;
    for (size_t r = 0; r < mask.height; ++r) {
      for (size_t c = 0; c < mask.width; ++c) {
        const bool hand = mask.data[r * mask.step + c] != 0;
        const bool kept = foreground.data[r * foreground.step + c] != 0;
        frame.hand += hand;
        frame.kept += kept;
        frame.kept_hand += hand && kept;
      }
    }
    if (region == SumOfGaussians::REGION_TRACKED) countOutsideRegion(camera, sog, foreground);
    if (frame.hand == 0) return;  // an image without the hand: precision is not defined
    for (Counts* total : {&all_, region == SumOfGaussians::REGION_TRACKED ? &tracked_ : nullptr}) {
      if (total == nullptr) continue;
      total->images += frame.images;
      total->hand += frame.hand;
      total->kept += frame.kept;
      total->kept_hand += frame.kept_hand;
    }
  }

  // The kept cells outside the tracked hand's region the SoG was segmented with.
  void countOutsideRegion(const Camera& camera, const SumOfGaussians& sog,
                          const sensor_msgs::Image& foreground) {
    const auto hand_region = camera.hand_regions.find(key(sog.region_stamp));
    if (hand_region == camera.hand_regions.end() || !camera.info) {
      ++regions_missing_;
      return;
    }
    const cv::Mat region = sag_hand_tracker::trackedRegionMask(
        *hand_region->second, sag_hand_tracker::fromCameraInfo(*camera.info));
    ++regions_checked_;
    for (size_t r = 0; r < foreground.height; ++r) {
      for (size_t c = 0; c < foreground.width; ++c) {
        if (foreground.data[r * foreground.step + c] == 0) continue;
        const int x = std::min(static_cast<int>(c) / cell_size_ * cell_size_ + cell_size_ / 2,
                               region.cols - 1);
        const int y = std::min(static_cast<int>(r) / cell_size_ * cell_size_ + cell_size_ / 2,
                               region.rows - 1);
        kept_outside_region_ += region.at<uint8_t>(y, x) == 0;
      }
    }
  }

  // Matches what can be matched and forgets it. Caller holds mutex_.
  void match(Camera* camera) {
    for (auto it = camera->foregrounds.begin(); it != camera->foregrounds.end();) {
      const auto mask = camera->masks.find(it->first);
      const auto sog = camera->sogs.find(it->first);
      if (mask == camera->masks.end() || sog == camera->sogs.end()) {
        ++it;
        continue;
      }
      count(*camera, *sog->second, *it->second, *mask->second);
      camera->masks.erase(mask);
      camera->sogs.erase(sog);
      it = camera->foregrounds.erase(it);
    }
  }

  std::mutex mutex_;
  std::vector<Camera> cameras_;
  Counts all_, tracked_;
  int mismatched_ = 0;
  int cell_size_ = 4;
  int regions_checked_ = 0, regions_missing_ = 0;
  long long kept_outside_region_ = 0;
  ros::WallTime last_foreground_;
  bool any_foreground_ = false;
};

TEST_F(ForegroundChecker, PrecisionInsideTheTrackedRegion) {
  ros::NodeHandle nh, pnh("~");
  const int num_cameras = pnh.param("num_cameras", 5);
  const double duration = pnh.param("duration", 60.0);
  const double idle_timeout = pnh.param("idle_timeout", 0.0);
  cell_size_ = pnh.param("cell_size", cell_size_);
  cameras_.resize(num_cameras);
  std::vector<ros::Subscriber> subscribers;
  for (int i = 0; i < num_cameras; ++i) {
    const std::string cam = "cam" + std::to_string(i);
    subscribers.push_back(nh.subscribe<SumOfGaussians>(
        cam + "/sog", 20, [this, i](const SumOfGaussians::ConstPtr& msg) {
          std::lock_guard<std::mutex> lock(mutex_);
          cameras_[i].sogs[key(msg->header.stamp)] = msg;
          match(&cameras_[i]);
        }));
    subscribers.push_back(nh.subscribe<sag_hand_tracker::HandRegion>(
        cam + "/hand_region", 20, [this, i](const sag_hand_tracker::HandRegion::ConstPtr& msg) {
          std::lock_guard<std::mutex> lock(mutex_);
          auto& regions = cameras_[i].hand_regions;
          regions[key(msg->header.stamp)] = msg;
          while (regions.size() > 100) regions.erase(regions.begin());
        }));
    subscribers.push_back(nh.subscribe<sensor_msgs::CameraInfo>(
        cam + "/camera_info", 2, [this, i](const sensor_msgs::CameraInfo::ConstPtr& msg) {
          std::lock_guard<std::mutex> lock(mutex_);
          cameras_[i].info = msg;
        }));
    subscribers.push_back(nh.subscribe<sensor_msgs::Image>(
        cam + "/foreground", 20, [this, i](const sensor_msgs::Image::ConstPtr& msg) {
          std::lock_guard<std::mutex> lock(mutex_);
          cameras_[i].foregrounds[key(msg->header.stamp)] = msg;
          last_foreground_ = ros::WallTime::now();
          any_foreground_ = true;
          match(&cameras_[i]);
        }));
    subscribers.push_back(nh.subscribe<sensor_msgs::Image>(
        cam + "/hand_mask", 20, [this, i](const sensor_msgs::Image::ConstPtr& msg) {
          std::lock_guard<std::mutex> lock(mutex_);
          cameras_[i].masks[key(msg->header.stamp)] = msg;
          match(&cameras_[i]);
        }));
  }
  ros::AsyncSpinner spinner(2);
  spinner.start();
  ASSERT_NO_FATAL_FAILURE(graph_test::prepareBag());
  graph_test::ReadyFileRemover remove_ready_file;
  const ros::WallTime start = ros::WallTime::now();
  while (ros::ok() && (ros::WallTime::now() - start).toSec() < duration) {
    ros::WallDuration(0.1).sleep();
    std::lock_guard<std::mutex> lock(mutex_);
    if (idle_timeout > 0 && any_foreground_ &&
        (ros::WallTime::now() - last_foreground_).toSec() > idle_timeout) {
      ROS_INFO("foreground_checker: no foreground for %.1f s, done", idle_timeout);
      break;
    }
  }
  spinner.stop();
  std::lock_guard<std::mutex> lock(mutex_);
  std::printf(
      "foreground_checker: %d images with the hand: precision %.1f %%, recall %.1f %%; inside the "
      "tracked hand's region: %d images, precision %.1f %%, recall %.1f %%\n",
      all_.images, 100.0 * all_.precision(), 100.0 * all_.recall(), tracked_.images,
      100.0 * tracked_.precision(), 100.0 * tracked_.recall());
  std::printf(
      "foreground_checker: %d tracked regions projected (%d not received), %lld kept pixels in "
      "cells outside them\n",
      regions_checked_, regions_missing_, kept_outside_region_);
  EXPECT_EQ(kept_outside_region_, 0);
  EXPECT_GE(regions_checked_, pnh.param("min_images", 100));
  EXPECT_EQ(mismatched_, 0) << "hand masks whose size or encoding does not match the foreground";
  EXPECT_GE(tracked_.images, pnh.param("min_images", 100));
  EXPECT_GE(tracked_.precision(), pnh.param("min_precision", 0.8));
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "foreground_checker");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
