// Synthetic studio driver nodelet: the studio's renderer (include/sag_hand_tracker/studio/) playing
// motion sequences one after another in real time, published like the live camera driver, plus
// the ground truth on its own topics. The embedded input of the demo and of the graph tests.
//
// Topics (relative to the nodelet's namespace), <name> = the rig's camera names (cam<i>):
//   out: <name>/image_raw (rgb8) + <name>/camera_info (image_transport::CameraPublisher; frame_id
//        <name>_optical_frame; every image of a set has the same stamp, ros::Time::now() taken
//        when the set is published, i.e. when a real camera set would have been read out)
//        /tf_static: the rig's extrinsics, root_frame -> <name>_optical_frame
//        ground_truth/joint_states (sensor_msgs/JointState: the 26 pose parameters, metres and
//          radians, HandModel::parameterNames() order), ground_truth/fingertips
//          (geometry_msgs/PoseArray thumb..pinky, frame = the rig's root frame); both stamped with
//          the set's stamp and published only for frames that show the hand
//        studio/sequence (std_msgs/String, latched): the sequence now playing; "done" after the
//          last one (without loop)
// Private parameters:
//   rig ("dexter5"): a built-in rig name, a directory with rig.yaml or a rig file
//   sequences (list, or a string of names separated by spaces or commas; default all seven
//     built-in motions): motion names or motion files, played
//     in order; each starts with empty_frames frames of the empty studio (the tracker loses the
//     hand there and starts again by itself when it reappears)
//   loop (false): start again with the first sequence after the last
//   fps (25): frame rate of the sequences and of the steady timer (60 is the other choice)
//   seed (1): seed of the motions' random parts and of the sensor noise
//   noise (2.0): sensor noise, 8-bit levels; motion_blur (1): sub-frames per frame
//   empty_frames (10): frames without the hand at the start of every sequence
//   lead_in_frames (15): extra empty frames before the first sequence, so that the segmentation
//     nodelets learn their background plate (default 10 frames) on frames without the hand
//   wait_for_subscribers (10.0 s): before the first frame, wait until every camera's image_raw
//     has a subscriber (at most this long; 0 = do not wait)
//   render_threads (1): threads that render a set's views (StudioRenderer::setRenderThreads; the
//     images are the same for any number); 1-16
//   render_ahead (2): sets rendered ahead of the timer, 1-16; each render waits after a set goes
//     out for the period less 1.5 x the slowest recent render, so that it stays out of the
//     graph's work on that set where the period leaves room (25 fps)
//   render_niceness (10): how much lower than the process the rendering threads run (nice
//     increment, 0-19), so that the graph's segmentation and tracking take the CPU first; a
//     real camera costs the host no CPU, and with the renderer at the graph's priority the
//     headless demo's p99 latency followed the renderer (doc/demo.md, sessions 10 and 11)
//   model ("sag"): the skeleton the hand is rendered on; config_dir (the package's config/)
//   hand ("default"): the rendered hand's proportions and skin: a shape of
//     config/hand_shapes.yaml (stocky, dark_small, ..) or drawn<N>, a hand drawn at random with
//     seed N (doc/studio.md); the ground truth is that hand's, the tracker keeps its own model
// Rendering runs ahead on a thread of its own (ProduceAhead, at render_niceness) and the timer,
// on a callback queue and thread of its own, publishes one rendered set per tick; neither takes
// one of the manager's worker threads away from the segmentation and the tracker. A set that is
// not ready at its tick goes out at the next one (the rate drops; no set is skipped).
#include <geometry_msgs/PoseArray.h>
#include <geometry_msgs/TransformStamped.h>
#include <image_transport/image_transport.h>
#include <nodelet/nodelet.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <std_msgs/String.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <pluginlib/class_list_macros.hpp>
#include "sag_hand_tracker/ros/image_transport_lock.h"
#include "sag_hand_tracker/ros/package_config.h"

#include <XmlRpcValue.h>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <memory>
#include <optional>
#include <sstream>

#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/ros/conversions.h"
#include "sag_hand_tracker/studio/hand_shapes.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/studio/renderer.h"
#include "sag_hand_tracker/studio/sequence.h"
#include "sag_hand_tracker/util/produce_ahead.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

class StudioDriverNodelet : public nodelet::Nodelet {
 public:
  ~StudioDriverNodelet() override {
    timer_.stop();
    if (spinner_) spinner_->stop();
    ahead_.reset();  // joins the rendering thread before the renderer and the sequence go
  }

 private:
  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    fps_ = pnh.param("fps", 25.0);
    if (!(fps_ > 0.0 && fps_ <= 1000.0)) {
      NODELET_FATAL("fps %g: must be in (0, 1000]; the studio does nothing", fps_);
      return;
    }
    loop_ = pnh.param("loop", false);
    seed_ = static_cast<std::uint64_t>(std::max(0, pnh.param("seed", 1)));
    empty_frames_ = std::max(0, pnh.param("empty_frames", 10));
    lead_in_frames_ = std::max(0, pnh.param("lead_in_frames", 15));
    motion_blur_ = std::max(1, pnh.param("motion_blur", 1));
    wait_for_subscribers_ = pnh.param("wait_for_subscribers", 10.0);
    render_threads_ = pnh.param("render_threads", 1);
    if (!(render_threads_ >= 1 && render_threads_ <= 16)) {
      NODELET_ERROR("render_threads must be in [1, 16] (got %d); using 1", render_threads_);
      render_threads_ = 1;
    }
    render_ahead_ = pnh.param("render_ahead", 2);
    if (!(render_ahead_ >= 1 && render_ahead_ <= 16)) {
      NODELET_ERROR("render_ahead must be in [1, 16] (got %d); using 2", render_ahead_);
      render_ahead_ = 2;
    }
    render_niceness_ = pnh.param("render_niceness", 10);
    if (!(render_niceness_ >= 0 && render_niceness_ <= 19)) {
      NODELET_ERROR("render_niceness must be in [0, 19] (got %d); using 10", render_niceness_);
      render_niceness_ = 10;
    }
    const std::string config_dir = packageConfigDir(pnh.param<std::string>("config_dir", ""));

    if (!readStringList(pnh, "sequences", &sequence_names_)) return;
    if (sequence_names_.empty()) sequence_names_ = studio::builtinMotionNames();

    studio::SensorParams sensor;
    sensor.noise_sigma = pnh.param("noise", 2.0);
    const std::string rig_name = pnh.param<std::string>("rig", "dexter5");
    const std::string model_name = pnh.param<std::string>("model", "sag");
    const std::string hand_name = pnh.param<std::string>("hand", "default");
    const auto setup_start = std::chrono::steady_clock::now();
    try {
      model_ = loadHandModel(resolveModelPath(model_name, config_dir));
      try {
        hand_ = studio::resolveHandShape(hand_name, config_dir);
      } catch (const InputError& e) {
        throw InputError(std::string("~hand: ") + e.what());
      }
      rig_ = loadCameraRig(studio::resolveRigPath(rig_name, config_dir));
      if (rig_.cameras.empty()) throw InputError("the rig '" + rig_name + "' has no cameras");
      // Every motion is loaded now, so that a bad name stops the driver at start, not mid-demo.
      for (const std::string& name : sequence_names_) {
        motions_.push_back(
            studio::loadMotion(studio::resolveMotionPath(name, config_dir), model_, seed_));
      }
      renderer_ = std::make_unique<studio::StudioRenderer>(rig_.cameras,
                                                           studio::StudioSceneParams(), sensor);
    } catch (const std::exception& e) {
      NODELET_FATAL("studio set-up failed: %s; the studio does nothing", e.what());
      return;
    }
    joint_names_ = model_.parameterNames();
    const double setup_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - setup_start).count();

    {
      std::lock_guard<std::mutex> plugins(imageTransportMutex());
      image_transport::ImageTransport it(nh);
      for (const Camera& camera : rig_.cameras) {
        Output out;
        out.frame_id = opticalFrame(camera.name);
        out.info = toCameraInfo(camera);
        out.publisher = it.advertiseCamera(camera.name + "/image_raw", 2);
        outputs_.push_back(std::move(out));
      }
    }
    gt_joint_pub_ = nh.advertise<sensor_msgs::JointState>("ground_truth/joint_states", 10);
    gt_fingertip_pub_ = nh.advertise<geometry_msgs::PoseArray>("ground_truth/fingertips", 10);
    sequence_pub_ = nh.advertise<std_msgs::String>("studio/sequence", 1, /*latch=*/true);
    publishExtrinsics();

    std::string list;
    for (const std::string& name : sequence_names_) list += (list.empty() ? "" : " ") + name;
    NODELET_INFO(
        "studio: rig '%s' (%zu cameras, %dx%d), hand '%s', sequences [%s]%s at %g fps, set-up "
        "%.1f s",
        rig_name.c_str(), rig_.cameras.size(), rig_.cameras[0].width, rig_.cameras[0].height,
        hand_.name.c_str(), list.c_str(), loop_ ? " looped" : "", fps_, setup_seconds);

    // Rendering ahead, and the timer on its own queue and thread (see the header comment).
    motions_frame_counts_.assign(motions_.size(), 0);
    ahead_ = std::make_unique<ProduceAhead<RenderedSet>>([this] { return renderNext(); },
                                                         render_ahead_, render_niceness_);
    render_nh_ = ros::NodeHandle(nh);
    render_nh_.setCallbackQueue(&render_queue_);
    spinner_ = std::make_unique<ros::AsyncSpinner>(1, &render_queue_);
    spinner_->start();
    wait_start_ = ros::WallTime::now();
    timer_ = render_nh_.createSteadyTimer(ros::WallDuration(1.0 / fps_),
                                          [this](const ros::SteadyTimerEvent&) { tick(); });
  }

  struct Output {
    std::string frame_id;
    sensor_msgs::CameraInfo info;
    image_transport::CameraPublisher publisher;
  };

  bool readStringList(const ros::NodeHandle& pnh, const std::string& key,
                      std::vector<std::string>* out) {
    out->clear();
    XmlRpc::XmlRpcValue value;
    if (!pnh.getParam(key, value)) return true;
    if (value.getType() == XmlRpc::XmlRpcValue::TypeString) {
      // "pinch random" or "pinch,random" (rosrun's _sequences:=... cannot give a list)
      std::string text = static_cast<std::string>(value);
      std::replace(text.begin(), text.end(), ',', ' ');
      std::istringstream words(text);
      for (std::string word; words >> word;) out->push_back(word);
      return true;
    }
    if (value.getType() != XmlRpc::XmlRpcValue::TypeArray) {
      NODELET_FATAL("parameter ~%s must be a list of names; the studio does nothing", key.c_str());
      return false;
    }
    for (int i = 0; i < value.size(); ++i) {
      if (value[i].getType() != XmlRpc::XmlRpcValue::TypeString) {
        NODELET_FATAL("parameter ~%s: entry %d is not a string; the studio does nothing",
                      key.c_str(), i);
        return false;
      }
      out->push_back(static_cast<std::string>(value[i]));
    }
    return true;
  }

  void publishExtrinsics() {
    std::vector<geometry_msgs::TransformStamped> transforms;
    const ros::Time now = ros::Time::now();
    for (size_t i = 0; i < rig_.cameras.size(); ++i) {
      geometry_msgs::TransformStamped transform;
      transform.header.stamp = now;
      transform.header.frame_id = rig_.root_frame;
      transform.child_frame_id = outputs_[i].frame_id;
      transform.transform = toTransformMsg(rig_.cameras[i].world_to_camera.inverse());
      transforms.push_back(transform);
    }
    static_broadcaster_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
    static_broadcaster_->sendTransform(transforms);
  }

  bool subscribersReady() const {
    for (const Output& out : outputs_) {
      if (out.publisher.getNumSubscribers() == 0) return false;
    }
    return true;
  }

  // A rendered set and where it is in the play list.
  struct RenderedSet {
    std::vector<studio::StudioImage> images;
    studio::StudioFrame frame;
    bool lead_in = false;
    std::optional<size_t> starts_sequence;  // the first set of this sequence (index)
  };

  // On the rendering thread (ProduceAhead), which owns the play state: the next set, or nothing
  // after the last sequence (without loop).
  std::optional<RenderedSet> renderNext() {
    if (!sequence_) {
      // Here, so that the renderer's helper threads start at this thread's lower priority.
      renderer_->setRenderThreads(render_threads_);
      lead_in_left_ = lead_in_frames_;
      startSequence(0);
    } else if (lead_in_left_ == 0 && frame_ >= sequence_->frameCount()) {
      if (sequence_index_ + 1 < motions_.size()) {
        startSequence(sequence_index_ + 1);
      } else if (loop_) {
        startSequence(0);
      } else {
        return std::nullopt;
      }
    }
    const auto render_start = std::chrono::steady_clock::now();
    RenderedSet set;
    if (frame_ == 0 && !sequence_announced_) {
      set.starts_sequence = sequence_index_;
      sequence_announced_ = true;
    }
    // Lead-in frames: the studio without the hand, before the first sequence's own empty frames.
    set.lead_in = lead_in_left_ > 0;
    const int k = set.lead_in ? 0 : frame_;
    set.frame = sequence_->frame(k);
    try {
      set.images = renderer_->render(
          set.lead_in ? std::vector<std::vector<studio::SurfacePart>>() : sequence_->surfaces(k),
          set.lead_in ? studio::mixSeed(sequence_->noiseSeed(0), 1000 + lead_in_left_)
                      : sequence_->noiseSeed(k));
    } catch (const std::exception& e) {
      throw std::runtime_error("rendering frame " + std::to_string(k) + " of '" +
                               sequence_names_[sequence_index_] + "' failed: " + e.what());
    }
    if (set.lead_in) {
      --lead_in_left_;
    } else {
      ++frame_;
    }
    holdOffFor(std::chrono::steady_clock::now() - render_start);
    return set;
  }

  // On the rendering thread; the timer hands the hold-off to ahead_ (which this thread may not
  // see assigned yet). Renders start as late as they can and still be ready at their tick, so that
  // they stay out of the graph's work on the set just published (at 25 fps ~20 ms after it; at 60
  // fps at once, as a set takes about a period): the period less 1.5 times the slowest of recent
  // renders.
  void holdOffFor(std::chrono::steady_clock::duration render_time) {
    const double seconds = std::chrono::duration<double>(render_time).count();
    recent_render_seconds_ = std::max(seconds, 0.95 * recent_render_seconds_);
    hold_off_seconds_ = std::max(0.0, 1.0 / fps_ - 1.5 * recent_render_seconds_);
  }

  void startSequence(size_t index) {
    studio::SequenceParams params;
    params.fps = fps_;
    params.seed = seed_;
    params.empty_frames = empty_frames_;
    params.motion_blur_samples = motion_blur_;
    params.exposure = std::min(params.exposure, 1.0 / fps_);
    params.shape = hand_.shape;
    params.surface.skin = hand_.skin;
    sequence_index_ = index;
    sequence_ = std::make_unique<studio::StudioSequence>(model_, motions_[index], params);
    motions_frame_counts_[index] = sequence_->frameCount();  // read by the timer once announced
    frame_ = 0;
    sequence_announced_ = false;
  }

  void announceSequence(size_t index) {
    std_msgs::String name;
    name.data = sequence_names_[index];
    sequence_pub_.publish(name);
    NODELET_INFO("studio: sequence %zu of %zu, '%s': %d frames (%.1f s)", index + 1,
                 motions_.size(), name.data.c_str(), motions_frame_counts_[index],
                 motions_frame_counts_[index] / fps_);
  }

  // One rendered set per timer event.
  void tick() {
    if (!started_) {
      const double waited = (ros::WallTime::now() - wait_start_).toSec();
      if (!subscribersReady() && waited < wait_for_subscribers_) return;
      if (wait_for_subscribers_ > 0 && !subscribersReady()) {
        NODELET_WARN("studio: not every camera has a subscriber after %.1f s; starting anyway",
                     waited);
      }
      started_ = true;
      rate_start_ = ros::WallTime::now();
    }
    if (finished_) return;
    ahead_->setHoldOff(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(hold_off_seconds_.load())));
    std::optional<RenderedSet> set = ahead_->tryTake();
    if (!set) {
      if (!ahead_->finished()) return;  // not rendered yet: it goes out at the next tick
      finished_ = true;
      timer_.stop();
      const std::string error = ahead_->error();
      if (!error.empty()) {
        NODELET_ERROR("studio: %s; the studio stops", error.c_str());
        return;
      }
      std_msgs::String done;
      done.data = "done";
      sequence_pub_.publish(done);
      NODELET_INFO("studio: all %zu sequences played (%ld sets published)", motions_.size(),
                   sets_published_);
      return;
    }
    if (set->starts_sequence) announceSequence(*set->starts_sequence);
    std_msgs::Header header;
    header.stamp = ros::Time::now();  // one stamp per set, when it goes out
    for (size_t i = 0; i < set->images.size(); ++i) {
      header.frame_id = outputs_[i].frame_id;
      auto image = boost::make_shared<sensor_msgs::Image>(toImageMsg(set->images[i].rgb, header));
      auto info = boost::make_shared<sensor_msgs::CameraInfo>(outputs_[i].info);
      info->header = header;
      outputs_[i].publisher.publish(image, info);
    }
    ++sets_published_;
    if (!set->lead_in && set->frame.hand_present) publishGroundTruth(set->frame, header.stamp);
    if (sets_published_ % static_cast<long>(std::max(1.0, 10.0 * fps_)) == 0) {
      const double seconds = (ros::WallTime::now() - rate_start_).toSec();
      NODELET_INFO("studio: %ld sets published, %.1f sets/s", sets_published_,
                   sets_published_ / std::max(seconds, 1e-9));
    }
  }

  void publishGroundTruth(const studio::StudioFrame& frame, const ros::Time& stamp) {
    std_msgs::Header header;
    header.stamp = stamp;
    header.frame_id = rig_.root_frame;
    gt_joint_pub_.publish(toJointStateMsg(joint_names_, frame.pose, header));
    gt_fingertip_pub_.publish(toFingertipsMsg(frame.fingertips, header));
  }

  double fps_ = 25.0;
  bool loop_ = false;
  std::uint64_t seed_ = 1;
  int empty_frames_ = 10;
  int lead_in_frames_ = 15;
  int motion_blur_ = 1;
  double wait_for_subscribers_ = 10.0;
  std::vector<std::string> sequence_names_;

  HandModel model_;
  studio::StudioHand hand_;  // the rendered hand's shape and skin (~hand)
  CameraRig rig_;
  std::vector<std::string> joint_names_;
  std::vector<studio::Motion> motions_;
  std::unique_ptr<studio::StudioRenderer> renderer_;
  int render_threads_ = 1;
  int render_ahead_ = 2;
  int render_niceness_ = 10;
  std::vector<int> motions_frame_counts_;  // per sequence, for the log
  // The play state, owned by the rendering thread (renderNext).
  std::unique_ptr<studio::StudioSequence> sequence_;
  size_t sequence_index_ = 0;
  int frame_ = 0;
  int lead_in_left_ = 0;
  bool sequence_announced_ = false;
  double recent_render_seconds_ = 0.0;                // the slowest of recent renders, decaying
  std::atomic<double> hold_off_seconds_{0.0};         // read by the timer
  std::unique_ptr<ProduceAhead<RenderedSet>> ahead_;  // after what renderNext uses
  // The timer's state.
  bool started_ = false;
  bool finished_ = false;
  long sets_published_ = 0;
  ros::WallTime wait_start_, rate_start_;

  std::vector<Output> outputs_;
  ros::Publisher gt_joint_pub_, gt_fingertip_pub_, sequence_pub_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> static_broadcaster_;
  ros::CallbackQueue render_queue_;
  ros::NodeHandle render_nh_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
  ros::SteadyTimer timer_;
};

}  // namespace sag_hand_tracker

PLUGINLIB_EXPORT_CLASS(sag_hand_tracker::StudioDriverNodelet, nodelet::Nodelet)
