// Segmentation nodelet, one per camera: image_raw + camera_info -> image SoG (the core's
// ImageSegmenter, the same code the offline tools run).
//
// Topics (relative to the nodelet's namespace, e.g. /cam0):
//   in:  image_raw (rgb8 or bgr8) with camera_info, paired by image_transport::CameraSubscriber
//   out: sog (sag_hand_tracker/SumOfGaussians, header = the image's header, means in raw pixels)
//        foreground (sensor_msgs/Image mono8, 255 = kept; only while it has subscribers: the
//        foreground the SoG was made of, for overlays and the graph tests' precision)
//   in (room_cues only): hand_region (sag_hand_tracker/HandRegion, from the tracker's
//        cam<i>/hand_region: the tracked hand in this camera's frame)
//   in: skin_gate (sag_hand_tracker/SkinGate; graph.launch remaps it to the tracker's latched
//        ~skin_gate: the skin gate around the colours of the user's calibrated model, at start and
//        after ~calibrate); it replaces the gate in use (skin_model's or the generic one)
// Lazy: the camera is subscribed only while `sog` has subscribers, so the plate too is learned
// only then.
// Private parameters: background_file (load the plate from it when it exists; "" = learn),
//   save_background (true: after learning, write the plate to background_file), room_cues (false;
//   the launch files set it to mode == skin: SegmentationParams::room.enabled, below),
//   region_timeout (0.5 s), max_candidates (4) and region_margin_cells (2) (MultiViewParams'
//   max_candidates_per_view, region_margin_cells), skin_model ("": a hand model file whose
//   colours are the user's, from calibrate_hand or ~calibrate; the skin gate is then the one
//   around them, personalSkinGate, as track_bag does with such a model; for a segmentation
//   without the tracker: in graph.launch the tracker sends its model's gate on skin_gate),
//   plus cfg/Segmentation.cfg (mode, quad-tree thresholds, background_frames,
//   relearn_background).
// Room cues (issue 11; ros/live_room_cues.h, doc/segmentation.md "The live graph"): with a fresh
//   tracked hand_region (stamped within region_timeout of the image) the foreground is kept inside
//   its projected silhouette (projectedHandMask with this camera_info; SoG region TRACKED and
//   region_stamp the hand_region's stamp; without a plate, what stays still outside the model's
//   own silhouette (trackedModelSilhouette) is dropped: RoomCueParams cue 7; with
//   candidates_wanted the whole image's hand candidates are attached for the tracker's re-check);
//   without one it is kept inside the union of the image's hand candidates, which are attached
//   (region CANDIDATES) for the tracker's multi-view check. Turn room_cues on together with the
//   tracker's (graph.launch's room_cues argument does).
// The plate is learned from the first background_frames images (the hand must be out of view);
// nothing is published for those images.
#include "sag_hand_tracker/HandRegion.h"
#include "sag_hand_tracker/SkinGate.h"
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
#include <string>

#include "sag_hand_tracker/SegmentationConfig.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/ros/checked_subscription.h"
#include "sag_hand_tracker/ros/conversions.h"
#include "sag_hand_tracker/ros/image_transport_lock.h"
#include "sag_hand_tracker/ros/live_room_cues.h"
#include "sag_hand_tracker/ros/sog_conversions.h"
#include "sag_hand_tracker/ros/throttled_warnings.h"
#include "sag_hand_tracker/segmentation/background_plate.h"
#include "sag_hand_tracker/segmentation/quadtree_segmentation.h"

namespace sag_hand_tracker {

class SegmentationNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    background_file_ = pnh.param<std::string>("background_file", "");
    save_background_ = pnh.param("save_background", false);
    room_cues_ = pnh.param("room_cues", false);
    region_timeout_ = pnh.param("region_timeout", region_timeout_);
    max_candidates_ = pnh.param("max_candidates", max_candidates_);
    region_margin_cells_ = pnh.param("region_margin_cells", region_margin_cells_);
    if (!(region_timeout_ > 0.0) || max_candidates_ < 1 || max_candidates_ > kMaxHandCandidates ||
        region_margin_cells_ < 0) {
      NODELET_ERROR(
          "region_timeout must be > 0, max_candidates in [1, %d], region_margin_cells >= 0 (got "
          "%g, %d, %d); using 0.5, 4, 2",
          kMaxHandCandidates, region_timeout_, max_candidates_, region_margin_cells_);
      region_timeout_ = 0.5;
      max_candidates_ = 4;
      region_margin_cells_ = 2;
    }
    {
      SegmentationParams params = segmenter_.params();
      params.room.enabled = room_cues_;
      params.skin = skinGateOf(pnh.param<std::string>("skin_model", ""), params.skin);
      segmenter_.setParams(params);
    }
    {
      std::lock_guard<std::mutex> plugins(imageTransportMutex());
      it_ = std::make_unique<image_transport::ImageTransport>(nh);
    }
    skin_gate_sub_ = subscribeChecked<SkinGate>(
        nh, "skin_gate", 1, [this](const SkinGate::ConstPtr& msg) { onSkinGate(*msg); },
        [this](const std::string& problem) {
          warn("malformed message on skin_gate dropped (" + problem + ")");
        });
    if (room_cues_) {
      region_sub_ = subscribeChecked<HandRegion>(
          nh, "hand_region", 2,
          [this](const HandRegion::ConstPtr& msg) {
            std::lock_guard<std::mutex> lock(mutex_);
            region_ = msg;
          },
          [this](const std::string& problem) {
            warn("malformed message on hand_region dropped (" + problem + ")");
          });
    }

    reconfigure_ =
        std::make_unique<dynamic_reconfigure::Server<SegmentationConfig>>(reconfigure_mutex_, pnh);
    reconfigure_->setCallback(
        [this](SegmentationConfig& config, uint32_t) { reconfigure(config); });
    loadBackgroundFile();

    sog_pub_ = nh.advertise<SumOfGaussians>("sog", 5);
    foreground_pub_ = nh.advertise<sensor_msgs::Image>("foreground", 5);
    // Lazy: the camera is subscribed while `sog` has subscribers. The count is polled (10 Hz)
    // rather than followed with connect/disconnect callbacks: with those, the manager crashed
    // inside roscpp's Publication::peerDisconnect during bag replay.
    subscription_timer_ = nh.createWallTimer(
        ros::WallDuration(0.1), [this](const ros::WallTimerEvent&) { updateSubscription(); });
  }

  // The user's skin gate from the colours of the model at `path` (skin_model), or `generic` when
  // there is no such model: a file that cannot be read, or colours that are not the user's.
  // A gate from the tracker (skin_gate): used from the next image on; a bad one is said and the
  // gate in use stays.
  void onSkinGate(const SkinGate& msg) {
    try {
      const SkinParams gate = skinGateFromMsg(msg);
      std::lock_guard<std::mutex> lock(mutex_);
      SegmentationParams params = segmenter_.params();
      params.skin = gate;
      segmenter_.setParams(params);
      skin_gate_note_.clear();  // skin_model's gate is replaced
      NODELET_INFO("skin gate from the tracker (%s): %s", msg.source.c_str(),
                   skinGateText(gate).c_str());
    } catch (const InputError& e) {
      warn(std::string("skin_gate message ignored, the skin gate in use stays: ") + e.what());
    }
  }

  // Logged now, and again with the first segmented image (skin_gate_note_).
  SkinParams skinGateOf(const std::string& path, const SkinParams& generic) {
    if (path.empty()) return generic;
    try {
      const HandModel model = loadHandModel(path);
      if (!model.colours_fitted) {
        skin_gate_note_ = "skin_model " + path +
                          ": its colours are not the user's (no 'colours: fitted'; calibrate_hand "
                          "or ~calibrate give them)";
        skin_gate_note_is_problem_ = true;
        NODELET_WARN("%s; the generic skin gate stays", skin_gate_note_.c_str());
        return generic;
      }
      const SkinParams gate = personalSkinGate(model);
      skin_gate_note_ = "the skin gate from " + path + ": " + skinGateText(gate);
      skin_gate_note_is_problem_ = false;
      NODELET_INFO("%s", skin_gate_note_.c_str());
      return gate;
    } catch (const std::exception& e) {
      skin_gate_note_ = std::string("skin_model: ") + e.what();
      skin_gate_note_is_problem_ = true;
      NODELET_ERROR("%s; the generic skin gate stays", skin_gate_note_.c_str());
      return generic;
    }
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
    std::lock_guard<std::mutex> plugins(imageTransportMutex());
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
    // Data shorter or longer than step * height, as the bag reader refuses it.
    const std::string layout = imageLayoutProblem(image);
    if (!layout.empty()) return layout;
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
      if (!skin_gate_note_.empty()) {
        // Said again with the first image it segments: the start-up line scrolls away, and a
        // skin_model that was not used changes what is kept in every image.
        if (skin_gate_note_is_problem_) {
          NODELET_WARN("segmenting with the generic skin gate: %s", skin_gate_note_.c_str());
        } else {
          NODELET_INFO("segmenting with %s", skin_gate_note_.c_str());
        }
        skin_gate_note_.clear();
      }
      std::vector<HandCandidate> candidates;
      std::uint8_t region = SumOfGaussians::REGION_NONE;
      if (room_cues_) region = setRoomRegion(rgb, *image, *info, &candidates);
      const ImageSoG sog = segmenter_.segmentFrame(rgb);
      SumOfGaussians msg = sogToMsg(sog);
      msg.header = image->header;
      msg.region = region;
      if (region == SumOfGaussians::REGION_TRACKED)
        msg.region_stamp = applied_region_->header.stamp;
      msg.candidates = candidatesToMsg(candidates);
      sog_pub_.publish(msg);
      if (foreground_pub_.getNumSubscribers() > 0) {
        foreground_pub_.publish(
            cv_bridge::CvImage(image->header, "mono8", segmenter_.lastForegroundMask())
                .toImageMsg());
      }
    } catch (const std::exception& e) {
      // E.g. the image size changed and no longer matches the learned plate.
      warn(std::string("segmentation failed, image skipped: ") + e.what());
    }
  }

  // The room cues' region of interest for this image (see the header comment); fills the
  // candidates to attach and returns the SoG's region. Caller holds mutex_.
  std::uint8_t setRoomRegion(const cv::Mat& rgb, const sensor_msgs::Image& image,
                             const sensor_msgs::CameraInfo& info,
                             std::vector<HandCandidate>* candidates) {
    if (region_ && region_->tracked &&
        regionIsFresh(region_->header.stamp.toSec(), image.header.stamp.toSec(), region_timeout_)) {
      try {
        if (region_ != applied_region_) {
          const Camera camera = fromCameraInfo(info);
          segmenter_.setRegionOfInterest(trackedRegionMask(*region_, camera), RegionSource::kTrack,
                                         segmenter_.usesModelSilhouette()
                                             ? trackedModelSilhouette(*region_, camera)
                                             : cv::Mat());
          applied_region_ = region_;
        }
        if (region_->candidates_wanted)
          *candidates = segmenter_.handCandidates(rgb, max_candidates_);
        return SumOfGaussians::REGION_TRACKED;
      } catch (const std::exception& e) {
        warn(std::string("hand_region ignored: ") + e.what());
      }
    }
    applied_region_.reset();
    *candidates = segmenter_.handCandidates(rgb, max_candidates_);
    segmenter_.setRegionOfInterest(
        candidatesRegionMask(*candidates, rgb.cols, rgb.rows, region_margin_cells_),
        RegionSource::kCandidates);
    return SumOfGaussians::REGION_CANDIDATES;
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
  bool room_cues_ = false;
  // What skin_model gave (skinGateOf), said once more with the first segmented image.
  std::string skin_gate_note_;
  bool skin_gate_note_is_problem_ = false;
  double region_timeout_ = 0.5;
  int max_candidates_ = 4;
  int region_margin_cells_ = 2;
  ros::Subscriber region_sub_;
  ros::Subscriber skin_gate_sub_;
  HandRegion::ConstPtr region_;          // the latest hand_region (guarded by mutex_)
  HandRegion::ConstPtr applied_region_;  // the one the segmenter's region comes from
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
  ros::Publisher foreground_pub_;
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<SegmentationConfig>> reconfigure_;
};

}  // namespace sag_hand_tracker

PLUGINLIB_EXPORT_CLASS(sag_hand_tracker::SegmentationNodelet, nodelet::Nodelet)
