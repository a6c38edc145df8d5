// Tracker nodelet: groups the N per-camera image SoGs by stamp, reads the extrinsics from tf, runs
// the core HandTracker and publishes the pose (joint_states, tf, markers, fingertips, status,
// diagnostics, optional overlay images), all stamped with the image stamp.
//
// Topics (relative to the nodelet's namespace), i = 0..num_cameras-1:
//   in:  cam<i>/sog (sag_hand_tracker/SumOfGaussians), cam<i>/camera_info,
//        cam<i>/image_raw (only while cam<i>/overlay has subscribers)
//   out: joint_states, markers, fingertips, status, cam<i>/overlay, /tf, /diagnostics,
//        cam<i>/hand_region (sag_hand_tracker/HandRegion; room_cues only),
//        cam<i>/skin_gate (sag_hand_tracker/SkinGate, latched: the skin gate around the model's
//        colours when they are the user's, at start and after each ~calibrate; each camera's
//        segmentation takes it)
//   service: ~calibrate (sag_hand_tracker/Calibrate, below)
// Private parameters: num_cameras (5), root_frame (world), model ("sag", "sog" or a path),
//   handedness (right|left), camera_timeout (0.5 s), time_jump_threshold (1.0 s),
//   stamp_tolerance (0.005 s: the SoGs of cameras whose stamps differ by at most this are one set;
//   0: identical stamps only),
//   calibration_max_frames (16) and calibration_rounds (2): the live fit's HandFitParams
//   max_frames and rounds, asynchronous_search (true: a set that needs the start or re-detection
//   search is handed to a worker thread, which tracks it and the sets after it synchronously
//   until it has caught up, off the frame path; false: the search runs on the set that needs it,
//   as track_bag does, so that a replay gives track_bag's poses exactly), catch_up_seconds (0.25;
//   with asynchronous_search: the worker keeps the sets of up to this many seconds; those that
//   got no pose on the frame path meanwhile are published late, below), worker_niceness (10: a
//   re-detecting worker's nice value above the frame path's; 0-19), search_threads (2: threads of
//   one start or re-detection search, which give the same result as one; 1-16), room_cues
//   (false; the launch files set it to mode == skin), multi_view (true), recheck_interval (1),
//   still_hypotheses (3; 0-16, 0 = a still scene never starts), still_retry_seconds (2.0) and
//   min_view_share (0.5; [0, 1): a start needs more than this share of the views with candidates,
//   5 cameras: 3; 0 = any 2)
//   (below), skin_gate_from_model (true: publish cam<i>/skin_gate, above; false: the
//   segmentations keep their own gate), mode (plate: the segmentations' mode; with skin the
//   starts are scored with the model's area charged, TrackerParams::start_model_area_weight, as
//   TrackingPipeline does offline without a plate, and 0 while the skin gate is the model's own;
//   and, with the generic gate and room_cues, searched again on the first set segmented in the
//   started hand's region, PipelineParams::redetect_in_started_region, as offline),
//   plus the dynamic_reconfigure parameters of cfg/Tracker.cfg (its start_model_area_weight, -1
//   by default, replaces the mode's weight when it is at least 0; its curled_refine_iterations,
//   -1 by default, the curled hand's refinement: as offline, on with mode plate and off with
//   mode skin; its rising_extra_iterations, 10, and size_calibrated_models, true, as offline);
//   the open finger toggles and the model's size adaptation as offline too
//   (TrackerParams::toggle_curled_flexion, size_step: on with mode plate, off with mode skin). The
//   tf, markers and fingertips are the tracker's model's, at the size it has taken.
//
// Room cues (issue 11; ros/live_room_cues.h, doc/segmentation.md "The live graph"; the segmentation
// nodelets' room_cues must be on too): after every set the tracked hand is published to each
// camera's segmentation on cam<i>/hand_region (the posed model in that camera's optical frame,
// stamped with the set; tracked false when there is none), which keeps its next images'
// foreground inside the hand's projected silhouette. Without a tracked hand the segmentations
// attach their hand candidates, and the multi-view check (MultiViewParams, `multi_view` =
// MultiViewParams::enabled) keeps in every camera only the Gaussians of the candidate that
// triangulates with the other views, or none; every recheck_interval sets the tracked hand is
// checked against the same choice and the track is reset when the choice replaces it. When
// nothing moving agrees (a hand held still from the first image), each of up to still_hypotheses
// places where still candidates agree is started by a tracker of its own on the frame path
// (startOnStillScene, as track_bag does; about 25 ms each) and the best becomes the track,
// provisional until the hand has moved 5 cm (re-checked every set meanwhile). After a set whose
// still places held no hand (a face, a photograph), the same places are tried again only after
// still_retry_seconds of image time (a new place at once), so that a still room does not cost the
// frame path the starts on every set (track_bag tries every set; LiveRoomCues::stillTrialsDue).
//
// Late results (catch-up, TrackerParams::catch_up_seconds): a set that got no pose while the
// worker had the search (no track, or it was lost) was published with a status without pose; its
// pose is published as soon as the worker has found it (joint_states, tf, fingertips, markers and
// a second status with has_pose and late true), with its own image stamp, oldest first, by a
// thread of the nodelet that the worker wakes (the frame path collects any it has not published
// before its own set). Sets beyond the bound stay lost. Late sets get no overlay
// images; a running ~calibrate collects them (it keeps the observations of the sets it saw
// without a pose until their late results come).
//
// Live calibration (~calibrate, srv/Calibrate.srv, doc/calibration.md "Live"): the call collects
// the sets of the next `duration` seconds (image stamps) as CalibrationFrames (the observations
// the tracker gets and its pose, for sets with a tracked hand) while tracking goes on (tracked
// meanwhile as calibrate_hand tracks a routine, RoutineTracking: whole ascents instead of races,
// no wrist prior, no curled hand's refinement, no extra iterations), checks the routine
// (checkCalibrationRoutine), fits (fitHandModel: the same fit as calibrate_hand, colours sampled
// from the image SoGs, which carry them) on a thread of its own, optionally writes the model file
// (atomic; never replaces a file), then rebuilds the HandTracker with the fitted model under
// mutex_. The service has its own callback queue and two threads: a call waiting for its frames or
// its fit takes none of the manager's worker threads, and a second call is answered (refused) at
// once.
//
// Synchronization: CameraSetSynchronizer (tracking/camera_set_synchronizer.h; message_filters'
// synchronizers take at most 9 inputs): a set is processed as soon as every camera that is not
// marked missing has delivered its SoG for that stamp; a camera silent for camera_timeout is left
// out until it delivers again; stamps or ROS time jumping back (a looping bag) reset the tracker.
// Markers and overlays: ros/visualization.h.
#include "sag_hand_tracker/SumOfGaussians.h"

#include <cv_bridge/cv_bridge.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/PoseArray.h>
#include <image_transport/image_transport.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/JointState.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>
#include <pluginlib/class_list_macros.hpp>
#include "sag_hand_tracker/ros/checked_subscription.h"
#include "sag_hand_tracker/ros/image_transport_lock.h"
#include "sag_hand_tracker/ros/package_config.h"

#include <ros/callback_queue.h>
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "sag_hand_tracker/Calibrate.h"
#include "sag_hand_tracker/TrackerConfig.h"
#include "sag_hand_tracker/TrackingStatus.h"
#include "sag_hand_tracker/fitting/hand_fit.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/ros/conversions.h"
#include "sag_hand_tracker/ros/live_room_cues.h"
#include "sag_hand_tracker/ros/sog_conversions.h"
#include "sag_hand_tracker/ros/throttled_warnings.h"
#include "sag_hand_tracker/ros/visualization.h"
#include "sag_hand_tracker/tracking/camera_set_synchronizer.h"
#include "sag_hand_tracker/tracking/tracker.h"
#include "sag_hand_tracker/tracking/tracking_pipeline.h"
#include "sag_hand_tracker/util/atomic_output.h"
#include "sag_hand_tracker/util/timing.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

class TrackerNodelet : public nodelet::Nodelet {
 public:
  ~TrackerNodelet() override {
    // A running calibration ends at once (its wait and its fit watch stopping_) and answers
    // "shutting down"; the service's threads are joined before the members they use go away.
    stopping_ = true;
    recording_done_.notify_all();
    if (calibration_spinner_) calibration_spinner_->stop();
    calibrate_srv_.shutdown();
    {
      std::lock_guard<std::mutex> lock(late_signal_->mutex);
      late_signal_->stop = true;
    }
    late_signal_->changed.notify_all();
    if (late_thread_.joinable()) late_thread_.join();
  }

 private:
  // The longest collection ~calibrate accepts (seconds): the frames are kept in memory and the
  // call blocks its caller for as long.
  static constexpr double kMaxCalibrationSeconds = 30.0;
  // The nice value of the fit's thread (the tracking threads keep the process's).
  static constexpr int kFitNiceness = 10;

  // The sets collected for a running ~calibrate call. Guarded by mutex_.
  struct CalibrationRecording {
    double duration = 0.0;
    std::optional<double> first_stamp;  // the first set after the call
    int sets = 0;
    std::vector<CalibrationFrame> frames;  // sets with a tracked hand
    bool complete = false;
    std::string interrupted;  // why the collection ended early ("" = it did not)
  };

  using Synchronizer = CameraSetSynchronizer<SumOfGaussians::ConstPtr>;
  struct CameraInput {
    ros::Subscriber sog_sub;
    ros::Subscriber info_sub;
    sensor_msgs::CameraInfo::ConstPtr info;
    image_transport::Publisher overlay_pub;
    ros::Publisher region_pub;     // cam<i>/hand_region (room_cues only)
    ros::Publisher skin_gate_pub;  // cam<i>/skin_gate, latched
    image_transport::Subscriber image_sub;
    std::deque<sensor_msgs::ImageConstPtr> images;  // recent images, for the overlay
  };

  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();
    num_cameras_ = pnh.param("num_cameras", 5);
    if (num_cameras_ < 1) {
      NODELET_ERROR("num_cameras must be >= 1 (got %d); using 1", num_cameras_);
      num_cameras_ = 1;
    }
    root_frame_ = pnh.param<std::string>("root_frame", "world");
    CameraSetSynchronizerParams sync_params;
    sync_params.num_cameras = num_cameras_;
    sync_params.camera_timeout = pnh.param("camera_timeout", 0.5);
    sync_params.time_jump_threshold = pnh.param("time_jump_threshold", 1.0);
    sync_params.stamp_tolerance = pnh.param("stamp_tolerance", sync_params.stamp_tolerance);
    if (!(sync_params.stamp_tolerance >= 0.0 && sync_params.stamp_tolerance <= 1.0)) {
      NODELET_ERROR("stamp_tolerance must be in [0, 1] s (got %g); using 0.005",
                    sync_params.stamp_tolerance);
      sync_params.stamp_tolerance = 0.005;
    }
    synchronizer_ = std::make_unique<Synchronizer>(sync_params);
    asynchronous_search_ = pnh.param("asynchronous_search", true);
    catch_up_seconds_ = pnh.param("catch_up_seconds", catch_up_seconds_);
    if (!(catch_up_seconds_ >= 0.0 && catch_up_seconds_ <= 10.0)) {
      NODELET_ERROR("catch_up_seconds must be in [0, 10] (got %g); using 0.25", catch_up_seconds_);
      catch_up_seconds_ = 0.25;
    }
    worker_niceness_ = pnh.param("worker_niceness", worker_niceness_);
    if (!(worker_niceness_ >= 0 && worker_niceness_ <= 19)) {
      NODELET_ERROR("worker_niceness must be in [0, 19] (got %d); using 10", worker_niceness_);
      worker_niceness_ = 10;
    }
    search_threads_ = pnh.param("search_threads", search_threads_);
    if (!(search_threads_ >= 1 && search_threads_ <= 16)) {
      NODELET_ERROR("search_threads must be in [1, 16] (got %d); using 2", search_threads_);
      search_threads_ = 2;
    }
    room_cues_ = pnh.param("room_cues", false);
    skin_mode_ = pnh.param<std::string>("mode", "plate") == "skin";
    skin_gate_from_model_ = pnh.param("skin_gate_from_model", true);
    {
      MultiViewParams multi_view;
      multi_view.enabled = pnh.param("multi_view", multi_view.enabled);
      multi_view.recheck_interval = pnh.param("recheck_interval", multi_view.recheck_interval);
      if (multi_view.recheck_interval < 0) {
        const int fallback = MultiViewParams().recheck_interval;
        NODELET_ERROR("recheck_interval must be >= 0 (got %d); using %d",
                      multi_view.recheck_interval, fallback);
        multi_view.recheck_interval = fallback;
      }
      multi_view.still_hypotheses = pnh.param("still_hypotheses", multi_view.still_hypotheses);
      if (multi_view.still_hypotheses < 0 || multi_view.still_hypotheses > 16) {
        const int fallback = MultiViewParams().still_hypotheses;
        NODELET_ERROR("still_hypotheses must be in [0, 16] (got %d); using %d",
                      multi_view.still_hypotheses, fallback);
        multi_view.still_hypotheses = fallback;
      }
      multi_view.min_view_share = pnh.param("min_view_share", multi_view.min_view_share);
      if (!(multi_view.min_view_share >= 0.0 && multi_view.min_view_share < 1.0)) {
        const double fallback = MultiViewParams().min_view_share;
        NODELET_ERROR("min_view_share must be in [0, 1) (got %g); using %g",
                      multi_view.min_view_share, fallback);
        multi_view.min_view_share = fallback;
      }
      double still_retry_seconds = pnh.param("still_retry_seconds", 2.0);
      if (!(still_retry_seconds >= 0.0 && still_retry_seconds <= 60.0)) {
        NODELET_ERROR("still_retry_seconds must be in [0, 60] (got %g); using 2",
                      still_retry_seconds);
        still_retry_seconds = 2.0;
      }
      room_ = LiveRoomCues(multi_view, still_retry_seconds);
    }
    const std::string model_name = pnh.param<std::string>("model", "sag");
    const std::string handedness = pnh.param<std::string>("handedness", "right");
    try {
      const std::string path = resolveModelPath(model_name, packageConfigDir());
      model_ = loadHandModel(path, handedness == "left" ? Handedness::kLeft : Handedness::kRight);
    } catch (const std::exception& e) {
      NODELET_FATAL("cannot load hand model '%s': %s", model_name.c_str(), e.what());
      throw;
    }
    model_label_ = model_name;
    tracker_ = std::make_unique<HandTracker>(model_, liveTrackerParams());
    // The worker signals each late result; this thread publishes it at once (header comment).
    tracker_->setLateResultCallback([signal = late_signal_]() {
      {
        std::lock_guard<std::mutex> lock(signal->mutex);
        signal->ready = true;
      }
      signal->changed.notify_one();
    });
    fit_params_.max_frames = pnh.param("calibration_max_frames", fit_params_.max_frames);
    fit_params_.rounds = pnh.param("calibration_rounds", fit_params_.rounds);
    if (fit_params_.max_frames < 1 || fit_params_.rounds < 1) {
      NODELET_ERROR(
          "calibration_max_frames and calibration_rounds must be >= 1 (got %d, %d); using 16, 2",
          fit_params_.max_frames, fit_params_.rounds);
      fit_params_.max_frames = 16;
      fit_params_.rounds = 2;
    }
    joint_names_ = model_.parameterNames();

    tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
    tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh);

    joint_pub_ = nh.advertise<sensor_msgs::JointState>("joint_states", 10);
    marker_pub_ = nh.advertise<visualization_msgs::MarkerArray>("markers", 2);
    fingertip_pub_ = nh.advertise<geometry_msgs::PoseArray>("fingertips", 10);
    status_pub_ = nh.advertise<TrackingStatus>("status", 10);

    std::unique_lock<std::mutex> plugins(imageTransportMutex());
    it_ = std::make_unique<image_transport::ImageTransport>(nh);
    cameras_.resize(num_cameras_);
    for (int i = 0; i < num_cameras_; ++i) {
      const std::string cam = "cam" + std::to_string(i);
      // Malformed messages from other processes are dropped with a warning
      // (ros/checked_subscription.h).
      auto malformed = [this, i, cam](const std::string& topic) {
        return [this, i, topic = cam + "/" + topic](const std::string& problem) {
          std::lock_guard<std::mutex> lock(mutex_);
          warnCamera(i, "malformed message on " + topic + " dropped (" + problem + ")");
        };
      };
      cameras_[i].sog_sub = subscribeChecked<SumOfGaussians>(
          nh, cam + "/sog", 5, [this, i](const SumOfGaussians::ConstPtr& msg) { onSoG(i, msg); },
          malformed("sog"));
      cameras_[i].info_sub = subscribeChecked<sensor_msgs::CameraInfo>(
          nh, cam + "/camera_info", 2,
          [this, i](const sensor_msgs::CameraInfo::ConstPtr& msg) {
            std::lock_guard<std::mutex> lock(mutex_);
            cameras_[i].info = msg;
          },
          malformed("camera_info"));
      // No connect callbacks: the timer below polls the subscriber count (see onTimer).
      cameras_[i].overlay_pub = it_->advertise(cam + "/overlay", 1);
      if (room_cues_) cameras_[i].region_pub = nh.advertise<HandRegion>(cam + "/hand_region", 2);
      cameras_[i].skin_gate_pub = nh.advertise<SkinGate>(cam + "/skin_gate", 1, /*latch=*/true);
    }
    plugins.unlock();
    users_skin_gate_ = publishSkinGate(model_, model_name);

    diagnostics_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, getName());
    diagnostics_->setHardwareID("sag_hand_tracker");
    diagnostics_->add("tracker", this, &TrackerNodelet::diagnose);

    reconfigure_ =
        std::make_unique<dynamic_reconfigure::Server<TrackerConfig>>(reconfigure_mutex_, pnh);
    reconfigure_->setCallback([this](TrackerConfig& config, uint32_t) { reconfigure(config); });

    // ~calibrate on a queue and threads of its own (see the header comment).
    ros::NodeHandle calibration_nh(pnh);
    calibration_nh.setCallbackQueue(&calibration_queue_);
    calibrate_srv_ =
        calibration_nh.advertiseService("calibrate", &TrackerNodelet::onCalibrate, this);
    calibration_spinner_ = std::make_unique<ros::AsyncSpinner>(2, &calibration_queue_);
    calibration_spinner_->start();

    // Processes sets whose cameras timed out, watches for ROS time jumping back, and follows the
    // overlay subscribers. (Polled rather than connect/disconnect callbacks: with those, the
    // manager crashed inside roscpp's Publication::peerDisconnect during bag replay.)
    timer_ = nh.createWallTimer(ros::WallDuration(std::max(0.01, sync_params.camera_timeout / 5.0)),
                                [this](const ros::WallTimerEvent&) {
                                  for (int i = 0; i < num_cameras_; ++i) {
                                    updateOverlaySubscription(i);
                                  }
                                  onTimer();
                                });
    late_thread_ = std::thread([this]() { publishLateResultsAsTheyCome(); });
    NODELET_INFO("tracker: %d cameras, root frame '%s', model '%s' (%zu Gaussians)", num_cameras_,
                 root_frame_.c_str(), model_.name.c_str(), model_.gaussians.size());
  }

  // The live graph runs the start and re-detection searches off the frame path (unless the
  // asynchronous_search parameter says otherwise).
  TrackerParams liveTrackerParams() const {
    TrackerParams params;
    params.asynchronous_search = asynchronous_search_;
    params.catch_up_seconds = catch_up_seconds_;
    params.worker_niceness = worker_niceness_;
    params.search_threads = search_threads_;
    return params;
  }

  void reconfigure(TrackerConfig& config) {
    TrackerParams params = liveTrackerParams();
    params.optimizer.iterations = config.iterations;
    params.rising_extra_iterations = config.rising_extra_iterations;
    try {
      params.optimizer.step_control = parseStepControl(config.step_control);
    } catch (const std::exception& e) {
      NODELET_WARN("step_control: %s; keeping rprop", e.what());
      config.step_control = "rprop";
    }
    params.optimizer.translation_step = config.translation_step;
    params.optimizer.rotation_step = config.rotation_step;
    params.optimizer.joint_step = config.joint_step;
    params.energy.limit_weight = config.limit_weight;
    params.energy.colour.hue_radius_deg = config.hue_radius_deg;
    params.energy.colour.saturation_radius = config.saturation_radius;
    params.energy.correct_colour_cast = config.correct_colour_cast;
    params.colour_adaptation.enabled = config.colour_adaptation;
    params.energy.model_weight = config.model_weight;
    params.curled_refine_iterations =
        config.curled_refine_iterations >= 0
            ? config.curled_refine_iterations
            : curledRefineIterations(PipelineParams(), skin_mode_);  // as offline
    params.toggle_curled_flexion = toggleCurledFlexion(PipelineParams(), skin_mode_);
    params.size_step = sizeStep(PipelineParams(), skin_mode_);
    params.size_calibrated_models = config.size_calibrated_models;
    params.lost_similarity = config.lost_similarity;
    params.min_foreground_gaussians = config.min_foreground_gaussians;
    params.min_cameras_for_start = config.min_cameras_for_start;
    std::lock_guard<std::mutex> lock(mutex_);
    configured_start_area_weight_ = config.start_model_area_weight;
    applyGateDependentSettings(&params);
    tracker_->setParams(params);
    // Read back from the tracker: what it now runs (the replay_reconfigure rostest checks it).
    NODELET_INFO(
        "tracker: parameters set: %d optimizer iterations per set (up to %d more while the ascent "
        "rises), the starts' model-area weight %g, %s",
        tracker_->params().optimizer.iterations, tracker_->params().rising_extra_iterations,
        tracker_->params().start_model_area_weight,
        redetect_in_started_region_ ? "a start searched again in its region"
                                    : "no search in a start's region");
    if (config.reset) {
      NODELET_INFO("tracker reset requested");
      resetTracker();
      room_.reset();
      config.reset = false;
    }
  }

  void onSoG(int camera, const SumOfGaussians::ConstPtr& msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    const ros::Time stamp = msg->header.stamp;
    if (stamp.isZero()) {
      warnCamera(camera, "message with a zero stamp, skipped");
      return;
    }
    const std::optional<Synchronizer::Set> set = synchronizer_->add(
        camera, static_cast<std::int64_t>(stamp.toNSec()), msg, ros::WallTime::now().toSec());
    handleSyncEvents();
    if (set) processSet(*set);
  }

  void onTimer() {
    std::lock_guard<std::mutex> lock(mutex_);
    synchronizer_->checkClock(ros::Time::now().toSec());
    handleSyncEvents();
    for (const Synchronizer::Set& set : synchronizer_->poll(ros::WallTime::now().toSec())) {
      handleSyncEvents();
      processSet(set);
    }
    handleSyncEvents();
    diagnostics_->update();
  }

  // Logs what the synchronizer reports and resets the tracker when time jumped back. Caller holds
  // mutex_.
  void handleSyncEvents() {
    const double timeout = synchronizer_->params().camera_timeout;
    for (const SyncEvent& event : synchronizer_->takeEvents()) {
      switch (event.kind) {
        case SyncEvent::Kind::kCameraMissing:
          NODELET_WARN("cam%d delivered no SoG for %.2f s: continuing without it", event.camera,
                       timeout);
          break;
        case SyncEvent::Kind::kCameraBack:
          NODELET_INFO("cam%d delivers again: waiting for it again", event.camera);
          break;
        case SyncEvent::Kind::kLate:
          warnCamera(event.camera, "SoG stamped " + std::to_string(event.seconds) +
                                       " s before the last processed set: ignored (late, or "
                                       "stamps going backwards)");
          break;
        case SyncEvent::Kind::kTimeJumpBack:
          NODELET_WARN(
              "time jumped back by %.3f s (bag loop?): resetting the tracker and its "
              "buffers",
              event.seconds);
          resetTracker();
          room_.reset();
          for (CameraInput& input : cameras_) input.images.clear();
          tf_buffer_->clear();
          if (recording_ && !recording_->complete) {
            recording_->interrupted = "time jumped back during the collection (bag loop?)";
            recording_->complete = true;
            recording_done_.notify_all();
          }
          break;
      }
    }
  }

  // Caller holds mutex_.
  void warnCamera(int camera, const std::string& problem) {
    if (warnings_.shouldWarn(camera, problem)) {
      NODELET_WARN("cam%d: %s", camera, problem.c_str());
    }
  }

  // Caller holds mutex_.
  void processSet(const Synchronizer::Set& set) {
    const auto start = std::chrono::steady_clock::now();
    ros::Time stamp;
    stamp.fromNSec(static_cast<std::uint64_t>(set.stamp_ns));
    std::vector<CameraObservation> observations;
    std::vector<int> observation_camera;
    std::vector<LiveView> views;  // room_cues: the observations' candidates
    for (int i = 0; i < num_cameras_; ++i) {
      if (!set.messages[i]) continue;
      std::string problem;
      CameraObservation observation;
      LiveView view;
      bool ok = makeObservation(i, **set.messages[i], &observation, &problem);
      if (ok && room_cues_) {
        try {
          view.region = (*set.messages[i])->region;
          view.candidates = candidatesFromMsg(**set.messages[i]);
        } catch (const std::exception& e) {
          problem = e.what();
          ok = false;
        }
      }
      if (ok) {
        if (room_cues_) views.push_back(std::move(view));
        observations.push_back(std::move(observation));
        observation_camera.push_back(i);
      } else {
        warnCamera(i, "skipped: " + problem);
        ++skipped_inputs_;
      }
    }
    LiveStillTrials still;
    if (room_cues_) applyRoomCues(&observations, &views, stamp.toSec(), &still);
    for (CameraObservation& observation : observations) {
      undistortImageSoG(observation.camera, &observation.sog);
    }
    FrameResult result;
    std::vector<FrameResult> late_results;
    bool still_start = false;
    try {
      if (!still.sogs.empty()) {
        still_start = tryStillScene(still, stamp.toSec(), set.stamp_ns, &observations, &result);
      }
      if (!still_start) {
        if (segmentedInStartedRegion(set)) {
          tracker_->requestRedetection();
          started_stamp_.reset();
        }
        result = tracker_->update(observations, stamp.toSec(), set.stamp_ns);
        late_results = tracker_->takeLateResults();
      }
    } catch (const std::exception& e) {
      NODELET_ERROR_THROTTLE(2.0, "tracker failed on the set at %.3f: %s", stamp.toSec(), e.what());
      resetTracker();
      room_.reset();
      return;
    }
    const double seconds = secondsSince(start);
    // The catch-up's sets first, oldest first, each with its own stamp.
    publishLateResults(late_results);
    noteStart(result);
    ++frames_;
    seconds_sum_ += seconds;
    last_result_ = result;
    last_seconds_ = seconds;
    const bool pose_ok = result.has_pose && result.pose.allFinite();
    if (result.has_pose && !pose_ok) {
      NODELET_ERROR_THROTTLE(2.0, "tracker returned a non-finite pose: not published; reset");
      resetTracker();
    }
    if (recording_) {
      record(stamp.toSec(), result, pose_ok, observations);
      // Its pose may still come late (the worker's): its observations are kept for it.
      if (!pose_ok) {
        awaiting_late_[set.stamp_ns] = observations;
        while (awaiting_late_.size() > static_cast<std::size_t>(kMaxCatchUpFrames)) {
          awaiting_late_.erase(awaiting_late_.begin());
        }
      }
    }
    PosedHand hand;
    if (pose_ok) {
      hand = forwardKinematics(tracker_->model(), result.pose);  // at the size it tracks with
      publishPose(stamp, result, hand);
      publishOverlays(stamp, observations, observation_camera, hand);
    }
    if (room_cues_) {
      room_.afterUpdate(pose_ok && result.status != TrackStatus::kLost ? &hand : nullptr,
                        still_start);
      publishRegions(stamp, observations, observation_camera, hand);
    }
    publishStatus(stamp, result, pose_ok, seconds);
  }

  // Before the tracker's update: the multi-view check and the re-check narrow the views' SoGs
  // (raw pixels) down to the hand; a re-check that replaces the track resets it; a still scene's
  // trials go to `still`. Caller holds mutex_.
  void applyRoomCues(std::vector<CameraObservation>* observations, std::vector<LiveView>* views,
                     double stamp, LiveStillTrials* still) {
    for (size_t v = 0; v < views->size(); ++v) {
      (*views)[v].camera = (*observations)[v].camera;
      (*views)[v].sog = std::move((*observations)[v].sog);
    }
    if (room_.beforeUpdate(views, still, stamp)) {
      NODELET_INFO("room cues: a hand that more views agree on replaces the track; restarting");
      resetTracker();
    }
    for (size_t v = 0; v < views->size(); ++v) {
      (*observations)[v].sog = std::move((*views)[v].sog);
    }
  }

  // A still scene (LiveStillTrials): each trial started by a tracker of its own on the set's
  // cameras, synchronously (startOnStillScene, as TrackingPipeline does offline); the best start
  // becomes this tracker's track, and its trial the set's observations. Returns whether one did;
  // otherwise the observations keep nothing (the views' Gaussians were not the hand's). Caller
  // holds mutex_.
  bool tryStillScene(const LiveStillTrials& still, double stamp, std::int64_t frame_id,
                     std::vector<CameraObservation>* observations, FrameResult* result) {
    std::vector<Camera> cameras;
    for (const CameraObservation& observation : *observations) {
      cameras.push_back(observation.camera);
    }
    std::vector<std::vector<CameraObservation>> trials;
    for (const std::vector<ImageSoG>& sogs : still.sogs) {
      std::vector<CameraObservation>& trial = trials.emplace_back(*observations);
      for (size_t v = 0; v < trial.size(); ++v) {
        trial[v].sog = sogs[v];
        undistortImageSoG(trial[v].camera, &trial[v].sog);
      }
    }
    const auto begin = std::chrono::steady_clock::now();
    std::optional<StillStart> start =
        startOnStillScene(tracker_->model(), tracker_->params(), trials, cameras, still.foregrounds,
                          room_.params().still_min_score, stamp, frame_id);
    const double ms = 1000.0 * secondsSince(begin);
    if (!start) {
      NODELET_INFO_THROTTLE(5.0,
                            "room cues: nothing moves; none of %zu still places is a hand (%.0f "
                            "ms); the same places are tried again in %.1f s, a new one at once",
                            trials.size(), ms, room_.stillRetrySeconds());
      return false;
    }
    NODELET_INFO(
        "room cues: nothing moves; started on still place %d of %zu (score %.2f, %.0f ms), "
        "provisional until the hand moves %.0f mm",
        start->hypothesis + 1, trials.size(), start->score, ms,
        1000.0 * room_.params().still_confirm_distance);
    tracker_->adoptTrack(*start->tracker);
    *observations = std::move(trials[start->hypothesis]);
    *result = start->result;
    return true;
  }

  // cam<i>/hand_region after a set: the tracked hand in each camera of the set, or "no tracked
  // hand" to every camera. Caller holds mutex_.
  void publishRegions(const ros::Time& stamp, const std::vector<CameraObservation>& observations,
                      const std::vector<int>& observation_camera, const PosedHand& hand) {
    if (!room_.tracking()) {
      HandRegion none;
      none.header.stamp = stamp;
      for (int i = 0; i < num_cameras_; ++i) {
        none.header.frame_id = "cam" + std::to_string(i) + "_optical_frame";
        cameras_[i].region_pub.publish(none);
      }
      return;
    }
    for (size_t o = 0; o < observations.size(); ++o) {
      HandRegion region = handRegionMsg(hand, observations[o].camera);
      region.header.stamp = stamp;
      region.header.frame_id = observations[o].camera.name + "_optical_frame";
      region.candidates_wanted = room_.candidatesWanted();
      cameras_[observation_camera[o]].region_pub.publish(region);
    }
  }

  // late_thread_: waits for the worker's signal, then publishes the late results it has found.
  void publishLateResultsAsTheyCome() {
    LateSignal& signal = *late_signal_;
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(signal.mutex);
        signal.changed.wait(lock, [&signal] { return signal.ready || signal.stop; });
        if (signal.stop) return;
        signal.ready = false;
      }
      std::lock_guard<std::mutex> lock(mutex_);
      std::vector<FrameResult> late_results;
      try {
        late_results = tracker_->takeReadyLateResults();
      } catch (const std::exception& e) {
        NODELET_ERROR_THROTTLE(2.0, "tracker failed while collecting late results: %s", e.what());
        continue;
      }
      publishLateResults(late_results);
    }
  }

  // The catch-up's results, oldest first, each with its own stamp; a running ~calibrate keeps
  // them. Caller holds mutex_.
  void publishLateResults(const std::vector<FrameResult>& late_results) {
    for (const FrameResult& late : late_results) {
      publishLateResult(late);
      if (recording_) recordLate(late);
      noteStart(late);
    }
  }

  // A late result of the catch-up (see the header comment): its stamp is its frame_id (the set's
  // stamp in ns, given to update). Caller holds mutex_.
  void publishLateResult(const FrameResult& result) {
    ros::Time stamp;
    stamp.fromNSec(static_cast<std::uint64_t>(result.frame_id));
    if (!result.has_pose || !result.pose.allFinite()) {
      NODELET_ERROR_THROTTLE(2.0,
                             "tracker returned a late result without a finite pose (set at "
                             "%.3f): not published",
                             stamp.toSec());
      return;
    }
    ++late_results_;
    publishPose(stamp, result, forwardKinematics(tracker_->model(), result.pose));
    publishStatus(stamp, result, true, 0.0);
  }

  // Caller holds mutex_.
  void publishStatus(const ros::Time& stamp, const FrameResult& result, bool pose_ok,
                     double seconds) {
    TrackingStatus status;
    status.header.stamp = stamp;
    status.header.frame_id = root_frame_;
    status.status = toString(result.status);
    status.has_pose = pose_ok;
    status.energy = std::isfinite(result.energy.total) ? result.energy.total : 0.0;
    status.similarity = std::isfinite(result.energy.similarity) ? result.energy.similarity : 0.0;
    status.num_cameras = result.num_cameras;
    status.expected_cameras = num_cameras_;
    status.seconds_per_frame = seconds;
    status.restarted = result.restarted;
    status.late = result.late;
    status.model = model_label_;
    status.calibration = calibrationState();
    status_pub_.publish(status);
  }

  // Adds a processed set to the running calibration's recording. Caller holds mutex_.
  // A late result during the collection: the set was counted when it came; its frame is kept now,
  // in stamp order, with the observations kept for it (frames of the start's search, which a
  // routine's fist or turned palm often needs).
  void recordLate(const FrameResult& result) {
    const auto kept = awaiting_late_.find(result.frame_id);
    if (kept == awaiting_late_.end()) return;
    CalibrationRecording& recording = *recording_;
    if (!recording.complete && result.has_pose && result.pose.allFinite() &&
        result.status != TrackStatus::kLost) {
      CalibrationFrame frame;
      frame.stamp = result.stamp;
      frame.observations = std::move(kept->second);
      frame.pose = result.pose;
      const auto later = std::upper_bound(
          recording.frames.begin(), recording.frames.end(), frame.stamp,
          [](double stamp, const CalibrationFrame& other) { return stamp < other.stamp; });
      recording.frames.insert(later, std::move(frame));
    }
    awaiting_late_.erase(kept);
  }

  void record(double stamp, const FrameResult& result, bool pose_ok,
              const std::vector<CameraObservation>& observations) {
    CalibrationRecording& recording = *recording_;
    if (recording.complete) return;
    if (!recording.first_stamp) recording.first_stamp = stamp;
    if (stamp - *recording.first_stamp > recording.duration) {
      recording.complete = true;
      recording_done_.notify_all();
      return;
    }
    ++recording.sets;
    // The frames calibrate_hand keeps: a pose, and the track not lost.
    if (pose_ok && result.status != TrackStatus::kLost) {
      CalibrationFrame frame;
      frame.stamp = stamp;
      frame.observations = observations;
      frame.pose = result.pose;
      recording.frames.push_back(std::move(frame));
    }
  }

  // ~calibrate: see the header comment and srv/Calibrate.srv. Runs on the service's own threads.
  bool onCalibrate(Calibrate::Request& request, Calibrate::Response& response) {
    const auto start = std::chrono::steady_clock::now();
    auto finish = [&](bool success, const std::string& message) {
      response.success = success;
      response.message = message;
      response.seconds = secondsSince(start);
      if (success) {
        NODELET_INFO("calibrate: %s", message.c_str());
      } else {
        NODELET_WARN("calibrate: refused or failed: %s", message.c_str());
      }
      return true;
    };
    // Checks that need no frames first, so that a bad request is answered at once.
    if (!(request.duration > 0.0 && request.duration <= kMaxCalibrationSeconds)) {
      std::ostringstream text;
      text << "duration must be in (0, " << kMaxCalibrationSeconds << "] seconds, got "
           << request.duration;
      return finish(false, text.str());
    }
    std::string problem;
    if (!request.save_path.empty() && !checkSavePath(request.save_path, &problem)) {
      return finish(false, problem);
    }
    bool idle = false;
    if (!calibrating_.compare_exchange_strong(idle, true)) {
      return finish(false,
                    "a calibration is already running; wait for its response before calling "
                    "~calibrate again");
    }
    struct Release {
      std::atomic<bool>* flag;
      ~Release() { *flag = false; }
    } release{&calibrating_};

    std::string message;
    const bool success = calibrate(request, &response, &message);
    setCalibrationState((success ? "fitted: " : "failed: ") + message);
    return finish(success, message);
  }

  // Sets what a routine is tracked without (RoutineTracking), or back what the tracker had; its
  // other parameters stay as they are (a reconfigure may have changed them meanwhile). Caller
  // holds mutex_.
  void setRoutineTracking(const RoutineTracking& routine) {
    TrackerParams params = tracker_->params();
    if (RoutineTracking::of(params) == routine) return;
    routine.applyTo(&params);
    tracker_->setParams(params);
  }

  // save_path must be absolute (the manager's working directory is nobody's business), name no
  // existing file, and lie in an existing folder. Fills `problem` when it does not.
  static bool checkSavePath(const std::string& path, std::string* problem) {
    namespace fs = std::filesystem;
    std::error_code error;
    const fs::path target(path);
    if (!target.is_absolute()) {
      *problem = "save_path '" + path + "' is not an absolute path";
    } else if (fs::exists(fs::symlink_status(target, error))) {
      *problem = "save_path " + path +
                 ": the file exists; ~calibrate does not replace files (remove it or choose "
                 "another name)";
    } else if (!fs::is_directory(target.parent_path(), error)) {
      *problem =
          "save_path " + path + ": the folder " + target.parent_path().string() + " does not exist";
    } else {
      return true;
    }
    return false;
  }

  // The body of ~calibrate once the request is accepted: collect, check, fit, save, switch.
  // Returns success; `message` says what was done or what went wrong.
  bool calibrate(const Calibrate::Request& request, Calibrate::Response* response,
                 std::string* message) {
    HandModel start_model;
    double start_size = 1.0;
    CalibrationRecording recording;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      recording_.emplace();
      recording_->duration = request.duration;
      // The routine is tracked as calibrate_hand tracks it (RoutineTracking: whole ascents, no
      // wrist prior, no curled hand's refinement, no extra iterations); the tracker's own
      // settings are back after it.
      const RoutineTracking live = RoutineTracking::of(tracker_->params());
      setRoutineTracking(RoutineTracking());
      setCalibrationState("collecting");
      NODELET_INFO("calibrate: collecting %.1f s of camera sets", request.duration);
      // Sets come at the camera rate; a replay may run slower than real time, so the wall-clock
      // limit is generous. It only matters when the sets stop coming.
      const auto deadline = std::chrono::steady_clock::now() +
                            std::chrono::duration<double>(2.0 * request.duration + 10.0);
      recording_done_.wait_until(
          lock, deadline, [this] { return stopping_ || recording_->complete || !ros::ok(); });
      recording = std::move(*recording_);
      recording_.reset();
      awaiting_late_.clear();
      // At the size the tracker ended the routine with (TrackerParams::size_step, RoutineTracking).
      start_size = tracker_->sizeFactor();
      start_model = scaleHandModel(model_, start_size, 1.0);
      setRoutineTracking(live);
    }
    response->sets = recording.sets;
    response->tracked_frames = static_cast<int>(recording.frames.size());
    if (stopping_ || !ros::ok()) {
      *message = "the tracker is shutting down";
      return false;
    }
    if (!recording.interrupted.empty()) {
      *message = recording.interrupted + "; nothing changed";
      return false;
    }
    if (recording.sets == 0) {
      *message = "no synchronized camera set arrived in " +
                 fixed(2.0 * request.duration + 10.0, 0) +
                 " s: are the cameras, the segmentation and tf running?";
      return false;
    }
    if (!recording.complete) {
      *message = "the camera sets stopped coming after " + std::to_string(recording.sets) +
                 " sets, before " + fixed(request.duration, 1) + " s were collected";
      return false;
    }

    const RoutineCheck routine =
        checkCalibrationRoutine(start_model, recording.frames, num_cameras_);
    if (!routine.ok) {
      *message = std::to_string(recording.sets) + " sets collected, " +
                 std::to_string(routine.frames) +
                 " with the hand; they do not show the calibration routine (open hand, palm and "
                 "back turned to the cameras, a fist; doc/calibration.md):";
      for (const std::string& item : routine.missing) *message += "\n  - " + item;
      return false;
    }

    setCalibrationState("fitting");
    NODELET_INFO(
        "calibrate: %zu frames with the hand; fitting (tracking goes on with the "
        "current model)",
        recording.frames.size());
    // The fit on a thread of its own; this service thread only waits for it.
    HandFitParams fit_params = fit_params_;
    fit_params.open_hand_frames = !routine.complete;  // as calibrate_hand
    std::future<HandFitResult> fitting =
        std::async(std::launch::async, [this, &start_model, &recording, &fit_params] {
          // Below the tracking threads: on a busy machine the fit waits, not the sets (Linux
          // gives each thread its own nice value).
          ::setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), kFitNiceness);
          return fitHandModel(
              start_model, recording.frames, fit_params,
              [this](double fraction, const std::string& status) {
                if (stopping_) throw InputError("the tracker is shutting down");
                setCalibrationState("fitting " + fixed(100.0 * fraction, 0) + " %: " + status);
              });
        });
    HandFitResult fit;
    try {
      fit = fitting.get();
    } catch (const std::exception& e) {
      *message = std::string("the fit failed: ") + e.what() + "; nothing changed";
      return false;
    }

    response->frames_used = static_cast<int>(fit.frame_indices.size());
    response->energy_before = fit.energy_before;
    response->energy_after = fit.energy_after;
    response->score_before = fit.score_before;
    response->score_after = fit.score_after;
    response->scale = fit.shape.scale;
    response->palm_width = fit.shape.palm_width;
    response->finger_length = fit.shape.finger_length;
    response->thickness = fit.shape.thickness;
    for (const Bone& bone : fit.model.bones) {
      response->bone_names.push_back(bone.name);
      response->bone_lengths.push_back(bone.length);
    }
    std::ostringstream summary;
    summary << "fitted on " << fit.frame_indices.size() << " of " << recording.frames.size()
            << " frames with the hand" << (fit.open_frames_only ? " (open hand)" : "") << " ("
            << recording.sets << " sets, " << routine.views << " views), from the model at the "
            << "tracker's size x" << fixed(start_size, 3) << ": size x" << fixed(fit.shape.scale, 3)
            << ", palm width x" << fixed(fit.shape.palm_width, 3) << ", finger length x"
            << fixed(fit.shape.finger_length, 3) << ", thickness x" << fixed(fit.shape.thickness, 3)
            << "; energy E " << fixed(fit.energy_before, 4) << " -> " << fixed(fit.energy_after, 4)
            << ", shape score " << fixed(fit.score_before, 4) << " -> "
            << fixed(fit.score_after, 4);
    if (!routine.complete) {
      // As calibrate_hand: a recording with the hand long enough is fitted from what it shows.
      summary << "; the sets did not show the whole routine:";
      for (const std::string& item : routine.missing) summary << " " << item << ";";
      summary << " fitted from what they show";
    }

    // Saved before the switch: when the file cannot be written, nothing changes.
    if (!request.save_path.empty()) {
      try {
        saveModel(fit.model, request.save_path);
      } catch (const std::exception& e) {
        *message = summary.str() + "; but the model was not saved: " + e.what() +
                   "; the tracker keeps its model";
        return false;
      }
      response->saved_path = request.save_path;
      summary << "; saved to " << request.save_path;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      model_ = fit.model;
      tracker_->setModel(model_);  // tracking goes on from the current pose
      model_label_ = request.save_path.empty() ? "fitted (not saved)" : request.save_path;
    }
    summary << "; the tracker now uses the fitted model";
    const bool users_gate =
        publishSkinGate(fit.model, request.save_path.empty() ? "~calibrate" : request.save_path);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      users_skin_gate_ = users_gate;
      TrackerParams params = tracker_->params();
      applyGateDependentSettings(&params);
      tracker_->setParams(params);
    }
    *message = summary.str();
    return true;
  }

  // The start's model-area weight (TrackerParams::start_model_area_weight) the tracker runs
  // with: 0 while the segmentations take the gate around the model's colours (publishSkinGate),
  // which drops the wood and the photographs the weight is for; else the configured one, and when
  // that is -1, TrackingPipeline's without a plate (PipelineParams::skin_gate_start_area_weight)
  // with mode skin and 0 with the plate, as offline. Caller holds mutex_.
  double startAreaWeight() const {
    if (users_skin_gate_) return 0.0;
    if (configured_start_area_weight_ >= 0.0) return configured_start_area_weight_;
    return startModelAreaWeight(PipelineParams(), skin_mode_);  // the tracker's default: 0
  }

  // What follows the segmentations' gate, as in TrackingPipeline: the start's model-area weight
  // (startAreaWeight, into `params`) and whether this nodelet asks for the search in a started
  // hand's region (redetectsInStartedRegion: the generic gate in mode skin, with the room cues).
  // Caller holds mutex_.
  void applyGateDependentSettings(TrackerParams* params) {
    params->start_model_area_weight = startAreaWeight();
    redetect_in_started_region_ =
        redetectsInStartedRegion(PipelineParams(), skin_mode_ && !users_skin_gate_, room_cues_);
    if (!redetect_in_started_region_) started_stamp_.reset();
  }

  // The tracker forgets its track, and a start waiting for its search goes with it. Caller holds
  // mutex_.
  void resetTracker() {
    tracker_->reset();
    started_stamp_.reset();
  }

  // A start (a first start, a restart, an adopted re-detection) that is still to be searched
  // again in its region (PipelineParams::redetect_in_started_region). Caller holds mutex_.
  void noteStart(const FrameResult& result) {
    if (!redetect_in_started_region_ || !result.has_pose ||
        result.status != TrackStatus::kStarted) {
      return;
    }
    started_stamp_ = started_stamp_ ? std::max(*started_stamp_, result.stamp) : result.stamp;
  }

  // Whether `set` is segmented in a started hand's region: at least half of its cameras used a
  // hand_region of the start's set or a later one (the regions reach the segmentations a set or
  // two after the tracker posts them). Caller holds mutex_.
  bool segmentedInStartedRegion(const Synchronizer::Set& set) const {
    if (!started_stamp_) return false;
    int cameras = 0, in_region = 0;
    for (int i = 0; i < num_cameras_; ++i) {
      if (!set.messages[i]) continue;
      const SumOfGaussians& msg = **set.messages[i];
      ++cameras;
      if (msg.region == SumOfGaussians::REGION_TRACKED &&
          msg.region_stamp.toSec() >= *started_stamp_ - 1e-6) {
        ++in_region;
      }
    }
    return cameras > 0 && 2 * in_region >= cameras;
  }

  // The segmentations' skin gate from `model`'s colours when they are the user's (latched on
  // cam<i>/skin_gate); colours that give no gate (personalSkinGate) are said and nothing is
  // published. Returns whether the gate was published.
  bool publishSkinGate(const HandModel& model, const std::string& source) {
    if (!skin_gate_from_model_ || !model.colours_fitted) return false;
    try {
      const SkinParams gate = personalSkinGate(model);
      SkinGate msg = skinGateMsg(gate, source);
      msg.header.stamp = ros::Time::now();
      for (CameraInput& camera : cameras_) camera.skin_gate_pub.publish(msg);
      NODELET_INFO("skin gate for the segmentations from %s: %s", source.c_str(),
                   skinGateText(gate).c_str());
      return true;
    } catch (const InputError& e) {
      NODELET_WARN("no skin gate from %s: %s", source.c_str(), e.what());
      return false;
    }
  }

  // Writes `model` to `path` through a temporary file that is loaded back before it is renamed;
  // refuses to replace a file that appeared meanwhile. Throws InputError.
  static void saveModel(const HandModel& model, const std::string& path) {
    AtomicOutputFile output(path, /*overwrite=*/false, "save_path");
    {
      std::ofstream file(output.tempPath());
      file << formatHandModel(model,
                              "Fitted live by the tracker's ~calibrate service.\n"
                              "Format: README.md, 'Hand models'.");
      file.flush();
      if (!file) throw InputError(path + ": cannot write the file");
    }
    loadHandModel(output.tempPath());
    std::string problem;
    if (!checkSavePath(path, &problem)) throw InputError(problem);
    output.commit();
  }

  // calibration_state_ has a mutex of its own: the fit reports its progress often and should not
  // wait for the tracker's sets.
  void setCalibrationState(const std::string& state) {
    std::lock_guard<std::mutex> lock(state_mutex_);
    calibration_state_ = state;
  }
  std::string calibrationState() {
    std::lock_guard<std::mutex> lock(state_mutex_);
    return calibration_state_;
  }

  static std::string fixed(double value, int digits) {
    char buffer[64];
    std::snprintf(buffer, sizeof(buffer), "%.*f", digits, value);
    return buffer;
  }

  // Caller holds mutex_.
  bool makeObservation(int i, const SumOfGaussians& msg, CameraObservation* observation,
                       std::string* problem) {
    const sensor_msgs::CameraInfo::ConstPtr& info = cameras_[i].info;
    if (!info) {
      *problem = "no camera_info received yet on cam" + std::to_string(i) + "/camera_info";
      return false;
    }
    if (msg.width != info->width || msg.height != info->height) {
      *problem = "SoG image size " + std::to_string(msg.width) + "x" + std::to_string(msg.height) +
                 " does not match camera_info " + std::to_string(info->width) + "x" +
                 std::to_string(info->height);
      return false;
    }
    const std::string cam = "cam" + std::to_string(i);
    const std::string frame =
        msg.header.frame_id.empty() ? cam + "_optical_frame" : msg.header.frame_id;
    geometry_msgs::TransformStamped transform;
    try {
      // Extrinsics are static: the latest transform is the one.
      transform = tf_buffer_->lookupTransform(root_frame_, frame, ros::Time(0));
    } catch (const tf2::TransformException& e) {
      *problem = "no tf from '" + root_frame_ + "' to '" + frame + "': " + e.what();
      return false;
    }
    try {
      observation->camera = fromCameraInfo(*info, cam);
      // tf gives the pose of the optical frame in the root frame; the camera wants root -> camera.
      observation->camera.world_to_camera = toIsometry(transform.transform).inverse();
      validateCamera(observation->camera);
      observation->sog = sogFromMsg(msg);  // raw pixels: processSet undistorts
    } catch (const std::exception& e) {
      *problem = e.what();
      return false;
    }
    return true;
  }

  void publishPose(const ros::Time& stamp, const FrameResult& result, const PosedHand& hand) {
    std_msgs::Header header;
    header.stamp = stamp;
    header.frame_id = root_frame_;
    joint_pub_.publish(toJointStateMsg(joint_names_, result.pose, header));

    std::vector<geometry_msgs::TransformStamped> transforms;
    for (size_t b = 0; b < model_.bones.size(); ++b) {
      geometry_msgs::TransformStamped t;
      t.header.stamp = stamp;
      t.header.frame_id = root_frame_;
      t.child_frame_id = "hand_" + model_.bones[b].name;
      t.transform = toTransformMsg(hand.bone_frames[b]);
      transforms.push_back(t);
    }
    tf_broadcaster_.sendTransform(transforms);

    fingertip_pub_.publish(toFingertipsMsg(result.fingertips, header));

    if (marker_pub_.getNumSubscribers() > 0) {
      marker_pub_.publish(makeHandMarkers(tracker_->model(), hand, header));
    }
  }

  // Overlay images: subscribe to cam<i>/image_raw only while someone watches cam<i>/overlay.
  void updateOverlaySubscription(int i) {
    std::lock_guard<std::mutex> lock(mutex_);
    CameraInput& input = cameras_[i];
    const bool wanted = input.overlay_pub.getNumSubscribers() > 0;
    std::lock_guard<std::mutex> plugins(imageTransportMutex());
    if (wanted && !input.image_sub) {
      input.image_sub = it_->subscribe("cam" + std::to_string(i) + "/image_raw", 2,
                                       [this, i](const sensor_msgs::ImageConstPtr& image) {
                                         std::lock_guard<std::mutex> lock(mutex_);
                                         auto& images = cameras_[i].images;
                                         images.push_back(image);
                                         while (images.size() > 30) images.pop_front();
                                       });
    } else if (!wanted && input.image_sub) {
      input.image_sub.shutdown();
      input.images.clear();
    }
  }

  void publishOverlays(const ros::Time& stamp, const std::vector<CameraObservation>& observations,
                       const std::vector<int>& observation_camera, const PosedHand& hand) {
    for (size_t o = 0; o < observations.size(); ++o) {
      CameraInput& input = cameras_[observation_camera[o]];
      if (input.overlay_pub.getNumSubscribers() == 0) continue;
      sensor_msgs::ImageConstPtr image;
      for (const auto& candidate : input.images) {
        if (candidate->header.stamp == stamp) image = candidate;
      }
      if (!image) continue;  // the image of this set has not arrived (yet)
      cv_bridge::CvImagePtr cv;
      try {
        cv = cv_bridge::toCvCopy(image, "bgr8");
      } catch (const std::exception& e) {
        warnCamera(observation_camera[o], std::string("overlay: ") + e.what());
        continue;
      }
      drawHandOverlay(observations[o].camera, hand, &cv->image);
      input.overlay_pub.publish(cv->toImageMsg());
    }
  }

  void diagnose(diagnostic_updater::DiagnosticStatusWrapper& stat) {
    // Called from onTimer with mutex_ held.
    const int missing = synchronizer_->missingCount();
    const SyncStatistics& sync = synchronizer_->statistics();
    if (frames_ == 0) {
      stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "no camera set received yet");
    } else if (missing > 0) {
      stat.summaryf(diagnostic_msgs::DiagnosticStatus::WARN, "%d of %d cameras missing; %s",
                    missing, num_cameras_, toString(last_result_.status).c_str());
    } else if (last_result_.status == TrackStatus::kLost ||
               last_result_.status == TrackStatus::kWaiting) {
      stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, toString(last_result_.status));
    } else {
      stat.summary(diagnostic_msgs::DiagnosticStatus::OK, toString(last_result_.status));
    }
    stat.add("frames", frames_);
    stat.add("mean seconds per frame", frames_ ? seconds_sum_ / frames_ : 0.0);
    stat.add("last seconds per frame", last_seconds_);
    stat.add("energy", last_result_.energy.total);
    stat.add("similarity", last_result_.energy.similarity);
    stat.add("cameras in last set", last_result_.num_cameras);
    stat.add("missing cameras", missing);
    stat.add("dropped incomplete sets", sync.dropped_sets);
    stat.add("late messages", sync.late_messages);
    stat.add("skipped camera inputs", skipped_inputs_);
    stat.add("late results (catch-up)", late_results_);
    stat.add("resets (time jumped back)", sync.resets);
    stat.add("model", model_label_);
    if (room_cues_) {
      stat.add("room cues: re-checks", room_.rechecks());
      stat.add("room cues: track switches", room_.switches());
    }
    stat.add("calibration", calibrationState());
  }

  int num_cameras_ = 5;
  std::string root_frame_;
  std::vector<std::string> joint_names_;
  HandFitParams fit_params_;

  std::mutex mutex_;  // guards everything below (callbacks may run on several threads)
  // The model and the tracker; replaced together by a live calibration.
  HandModel model_;
  bool asynchronous_search_ = true;
  bool room_cues_ = false;
  LiveRoomCues room_;  // room_cues: the multi-view check and the tracked hand's regions
  double catch_up_seconds_ = 0.25;
  int worker_niceness_ = 10;
  int search_threads_ = 2;
  std::unique_ptr<HandTracker> tracker_;
  std::string model_label_;  // for the status: the model parameter, or the saved file
  std::optional<CalibrationRecording> recording_;  // while a ~calibrate call collects
  // While it collects: the observations of the sets reported without a pose, by frame id, for
  // their late results.
  std::map<std::int64_t, std::vector<CameraObservation>> awaiting_late_;
  std::condition_variable recording_done_;
  std::vector<CameraInput> cameras_;
  std::unique_ptr<Synchronizer> synchronizer_;
  ThrottledWarnings warnings_;
  FrameResult last_result_;
  double last_seconds_ = 0.0, seconds_sum_ = 0.0;
  long frames_ = 0, skipped_inputs_ = 0, late_results_ = 0;

  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  std::unique_ptr<image_transport::ImageTransport> it_;
  ros::Publisher joint_pub_, marker_pub_, fingertip_pub_, status_pub_;
  bool skin_gate_from_model_ = true;            // publish cam<i>/skin_gate
  bool skin_mode_ = false;                      // ~mode == skin: the segmentations have no plate
  bool users_skin_gate_ = false;                // publishSkinGate published the model's own gate
  bool redetect_in_started_region_ = false;     // applyGateDependentSettings
  std::optional<double> started_stamp_;         // noteStart: a start not yet searched in its region
  double configured_start_area_weight_ = -1.0;  // cfg/Tracker.cfg start_model_area_weight
  std::unique_ptr<diagnostic_updater::Updater> diagnostics_;
  boost::recursive_mutex reconfigure_mutex_;
  std::unique_ptr<dynamic_reconfigure::Server<TrackerConfig>> reconfigure_;
  ros::WallTimer timer_;

  // ~calibrate (its own queue and threads; see the header comment).
  std::mutex state_mutex_;
  std::string calibration_state_;         // for the status (TrackingStatus.calibration)
  std::atomic<bool> calibrating_{false};  // a call has been accepted and has not answered yet
  std::atomic<bool> stopping_{false};     // the nodelet is being destroyed
  ros::CallbackQueue calibration_queue_;
  ros::ServiceServer calibrate_srv_;
  std::unique_ptr<ros::AsyncSpinner> calibration_spinner_;

  // The worker's signal that a late result is ready (HandTracker::setLateResultCallback), shared
  // with the callback, which a worker may call until it has ended.
  struct LateSignal {
    std::mutex mutex;
    std::condition_variable changed;
    bool ready = false;
    bool stop = false;
  };
  std::shared_ptr<LateSignal> late_signal_ = std::make_shared<LateSignal>();
  std::thread late_thread_;  // publishLateResultsAsTheyCome
};

}  // namespace sag_hand_tracker

PLUGINLIB_EXPORT_CLASS(sag_hand_tracker::TrackerNodelet, nodelet::Nodelet)
