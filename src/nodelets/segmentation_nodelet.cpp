// Segmentation nodelet, one per camera: image_raw + camera_info -> image SoG (the core's
// ImageSegmenter, the same code the offline tools run).
//
// Topics (relative to the nodelet's namespace, e.g. /cam0):
//   in:  image_raw (rgb8 or bgr8) with camera_info, paired by image_transport::CameraSubscriber
//   out: sog (sag_hand_tracker/SumOfGaussians, header = the image's header, means in raw pixels)
// Lazy: the camera is subscribed only while `sog` has subscribers, so the plate too is learned
// only then.
// Private parameters: background_file (load the plate from it when it exists; "" = learn),
//   save_background (true: after learning, write the plate to background_file), plus
//   cfg/Segmentation.cfg (mode, quad-tree thresholds, background_frames, relearn_background).
// The plate is learned from the first background_frames images (the hand must be out of view);
// nothing is published for those images.
#include "sag_hand_tracker/SumOfGaussians.h"

#include <cv_bridge/cv_bridge.h>
#include <dynamic_reconfigure/server.h>
#include <image_transport/image_transport.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/image_encodings.h>
#include <pluginlib/class_list_macros.hpp>

#include <fstream>
#include <memory>
#include <mutex>
#include <opencv2/imgproc.hpp>

#include "sag_hand_tracker/SegmentationConfig.h"
#include "sag_hand_tracker/ros/sog_conversions.h"
#include "sag_hand_tracker/ros/throttled_warnings.h"
#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"

namespace sag_hand_tracker {

class SegmentationNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    background_file_ = pnh.param<std::string>("background_file", "");
    save_background_ = pnh.param("save_background", false);
    it_ = std::make_unique<image_transport::ImageTransport>(nh);

    reconfigure_ =
        std::make_unique<dynamic_reconfigure::Server<SegmentationConfig>>(reconfigure_mutex_, pnh);
    reconfigure_->setCallback(
        [this](SegmentationConfig& config, uint32_t) { reconfigure(config); });
    loadBackgroundFile();

    sog_pub_ = nh.advertise<SumOfGaussians>("sog", 5);
    // Lazy: the camera is subscribed while `sog` has subscribers. The count is polled (10 Hz)
    // rather than followed with connect/disconnect callbacks: with those, the manager crashed
    // inside roscpp's Publication::peerDisconnect during bag replay.
    subscription_timer_ = nh.createWallTimer(
        ros::WallDuration(0.1), [this](const ros::WallTimerEvent&) { updateSubscription(); });
  }

  void loadBackgroundFile() {
    if (background_file_.empty() || !std::ifstream(background_file_).good()) return;
    std::lock_guard<std::mutex> lock(mutex_);
    try {
      segmenter_.loadBackground(background_file_);
      NODELET_INFO("background plate loaded from %s (%d frames)", background_file_.c_str(),
                   segmenter_.backgroundFrameCount());
    } catch (const std::exception& e) {
      NODELET_ERROR("cannot load the background plate: %s; learning it instead", e.what());
    }
  }

  void reconfigure(SegmentationConfig& config) {
    SegmentationParams params;
    std::lock_guard<std::mutex> lock(mutex_);
    params = segmenter_.params();
    try {
      params.mode = parseSegmentationMode(config.mode);
      params.cell_size = config.cell_size;
      params.quadtree.min_leaf_size = config.min_leaf_size;
      params.quadtree.max_leaf_size = config.max_leaf_size;
      params.quadtree.max_colour_std = config.max_colour_std;
      params.background.frames = config.background_frames;
      params.background.k_sigma = config.k_sigma;
      params.background.min_tolerance = config.min_tolerance;
      segmenter_.setParams(params);  // validates
    } catch (const std::exception& e) {
      NODELET_ERROR("segmentation parameters rejected, keeping the previous ones: %s", e.what());
    }
    if (config.relearn_background) {
      segmenter_.resetBackground();
      learned_logged_ = false;
      config.relearn_background = false;
      NODELET_INFO("background plate: relearning from the next %d frames",
                   segmenter_.params().background.frames);
    }
  }

  void updateSubscription() {
    std::lock_guard<std::mutex> lock(subscription_mutex_);
    if (sog_pub_.getNumSubscribers() > 0) {
      if (!camera_sub_) {
        camera_sub_ = it_->subscribeCamera(
            "image_raw", 2,
            [this](const sensor_msgs::ImageConstPtr& image,
                   const sensor_msgs::CameraInfoConstPtr& info) { onImage(image, info); });
      }
    } else if (camera_sub_) {
      camera_sub_.shutdown();
    }
  }

  // Returns an empty string when the input is usable, else what is wrong with it.
  static std::string checkInput(const sensor_msgs::Image& image,
                                const sensor_msgs::CameraInfo& info) {
    namespace enc = sensor_msgs::image_encodings;
    if (image.width == 0 || image.height == 0 || image.data.empty()) return "empty image";
    if (image.encoding != enc::RGB8 && image.encoding != enc::BGR8) {
      return "encoding '" + image.encoding + "' not supported (rgb8 or bgr8)";
    }
    if (image.step < image.width * 3 ||
        image.data.size() < static_cast<size_t>(image.step) * image.height) {
      return "image data shorter than step * height";
    }
    if (image.width != info.width || image.height != info.height) {
      return "image size " + std::to_string(image.width) + "x" + std::to_string(image.height) +
             " does not match camera_info " + std::to_string(info.width) + "x" +
             std::to_string(info.height);
    }
    return "";
  }

  void onImage(const sensor_msgs::ImageConstPtr& image,
               const sensor_msgs::CameraInfoConstPtr& info) {
    const std::string problem = checkInput(*image, *info);
    if (!problem.empty()) {
      warn("image skipped: " + problem);
      return;
    }
    cv::Mat rgb;
    try {
      cv_bridge::CvImageConstPtr cv = cv_bridge::toCvShare(image);
      if (image->encoding == sensor_msgs::image_encodings::BGR8) {
        cv::cvtColor(cv->image, rgb, cv::COLOR_BGR2RGB);
      } else {
        rgb = cv->image.clone();
      }
    } catch (const std::exception& e) {
      warn(std::string("image conversion failed: ") + e.what());
      return;
    }
    std::lock_guard<std::mutex> lock(mutex_);
    try {
      const SegmentationMode mode = segmenter_.params().mode;
      const bool needs_plate =
          mode == SegmentationMode::kPlate || mode == SegmentationMode::kPlateAndSkin;
      if (needs_plate && !segmenter_.backgroundReady()) {
        segmenter_.addBackgroundFrame(rgb);
        NODELET_INFO_THROTTLE(2.0, "learning the background plate: %d of %d frames",
                              segmenter_.backgroundFrameCount(),
                              segmenter_.params().background.frames);
        if (segmenter_.backgroundReady() && !learned_logged_) {
          learned_logged_ = true;
          NODELET_INFO("background plate learned");
          if (save_background_ && !background_file_.empty()) {
            segmenter_.saveBackground(background_file_);
            NODELET_INFO("background plate saved to %s", background_file_.c_str());
          }
        }
        return;
      }
      const ImageSoG sog = segmenter_.segmentFrame(rgb);
      SumOfGaussians msg = sogToMsg(sog);
      msg.header = image->header;
      sog_pub_.publish(msg);
    } catch (const std::exception& e) {
      // E.g. the image size changed and no longer matches the learned plate.
      warn(std::string("segmentation failed, image skipped: ") + e.what());
    }
  }

  // Throttled per kind of problem, so that one does not hide another.
  void warn(const std::string& problem) {
    std::lock_guard<std::mutex> lock(warnings_mutex_);
    if (warnings_.shouldWarn(-1, problem)) {
      NODELET_WARN("%s: %s", getNodeHandle().resolveName("image_raw").c_str(), problem.c_str());
    }
  }

  std::string background_file_;
  bool save_background_ = false;
  bool learned_logged_ = false;
  std::mutex mutex_;  // guards segmenter_
  std::mutex warnings_mutex_;
  ThrottledWarnings warnings_;
  ImageSegmenter segmenter_;
  std::mutex subscription_mutex_;
  ros::WallTimer subscription_timer_;
  std::unique_ptr<image_transport::ImageTransport> it_;
  image_transport::CameraSubscriber camera_sub_;
  ros::Publisher sog_pub_;
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<SegmentationConfig>> reconfigure_;
};

}  // namespace sag_hand_tracker

PLUGINLIB_EXPORT_CLASS(sag_hand_tracker::SegmentationNodelet, nodelet::Nodelet)
