// Camera driver nodelet for live input: N cameras (V4L2 devices, video files or image folders),
// captured together and published as synchronized sets (the core's MultiCapture: every camera is
// grabbed first, then each is retrieved; the whole set gets ONE stamp).
//
// Topics (relative to the nodelet's namespace), <name> = camera_names[i] (default cam<i>):
//   out: <name>/image_raw (rgb8, width x height) + <name>/camera_info, through an
//        image_transport::CameraPublisher; frame_id <name>_optical_frame; /tf_static (rig_file)
//   services: <name>/set_camera_info (camera_info_manager)
// Private parameters:
//   sources (list, required): per camera "0" / 0 (V4L2 index), "/dev/video0", a video file, or
//     "dir:/path" (an image folder, read in sorted file name order)
//   num_cameras (-1): when >= 0, the number of entries sources must have (a launch file's
//     check that its camera count and its source list agree)
//   camera_names (list, default cam0..cam<N-1>)
//   camera_info_urls (list, one per camera, "" = none): package:// or file:// calibration
//     (camera_info_manager). A camera without a url gets its intrinsics from rig_file when the
//     rig has it, else camera_info_manager's default url (file://$ROS_HOME/camera_info/<name>.yaml)
//   rig_file (""): the rig's extrinsics (calibration.h), published as static tf
//     root_frame -> <name>_optical_frame for every camera of the driver that the rig has
//   width (320), height (240): output size; frames of another size are resized (warned once);
//     0 keeps the source's size. Also requested from devices, like fps and fourcc.
//   fps (25): capture rate (a steady timer); fourcc ("", e.g. "MJPG"): pixel format for devices
//   loop (false): video files and folders start again at their end
//   max_failures (fps, i.e. about a second): consecutive failed grabs before a camera is
//     declared stopped
//   reopen (true): a camera that stopped or could not be opened is opened again, first
//     reopen_first_delay (0.5) s after, then with the wait doubling up to reopen_max_delay (8) s;
//     every failed attempt is a WARN naming the camera and the next wait, success an INFO
// A camera that cannot be opened, or that stops (max_failures failed grabs, or the end of its
// file or folder without loop), is logged once as an ERROR naming it; the others keep publishing.
// When frames are resized to width x height, the camera_info (K, P, width, height) of a
// calibration made at another size is rescaled to match (scaleIntrinsics), logged once.
#include <camera_info_manager/camera_info_manager.h>
#include <geometry_msgs/TransformStamped.h>
#include <image_transport/image_transport.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <pluginlib/class_list_macros.hpp>

#include <XmlRpcValue.h>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <memory>
#include <optional>

#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/capture/capture.h"
#include "sag_hand_tracker/ros/conversions.h"
#include "sag_hand_tracker/ros/image_transport_lock.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

class CameraDriverNodelet : public nodelet::Nodelet {
 private:
  struct Output {
    std::string name;
    std::string frame_id;
    image_transport::CameraPublisher publisher;
    std::unique_ptr<camera_info_manager::CameraInfoManager> info_manager;
    bool info_size_warned = false;
    bool info_scaled_logged = false;
    bool uncalibrated_warned = false;
    ros::WallTime last_failure_warning;
  };

  void onInit() override {
    ros::NodeHandle& nh = getNodeHandle();
    ros::NodeHandle& pnh = getPrivateNodeHandle();

    std::vector<std::string> sources;
    std::vector<std::string> names;
    std::vector<std::string> urls;
    if (!readStringList(pnh, "sources", &sources) || sources.empty()) {
      NODELET_FATAL(
          "parameter ~sources must be a non-empty list (device index, /dev/video<k>, "
          "video file or dir:/folder per camera); the driver does nothing");
      return;
    }
    const int count = static_cast<int>(sources.size());
    const int expected = pnh.param("num_cameras", -1);
    if (expected >= 0 && expected != count) {
      NODELET_FATAL("num_cameras is %d but ~sources lists %d cameras; the driver does nothing",
                    expected, count);
      return;
    }
    if (!readStringList(pnh, "camera_names", &names)) return;
    if (names.empty()) {
      for (int i = 0; i < count; ++i) names.push_back("cam" + std::to_string(i));
    }
    if (!readStringList(pnh, "camera_info_urls", &urls)) return;
    if (urls.empty()) urls.assign(count, "");
    if (static_cast<int>(names.size()) != count || static_cast<int>(urls.size()) != count) {
      NODELET_FATAL(
          "%d sources but %zu camera_names and %zu camera_info_urls: give one per "
          "camera (or none); the driver does nothing",
          count, names.size(), urls.size());
      return;
    }
    for (const std::string& name : names) {
      if (!validCameraName(name)) {
        NODELET_FATAL(
            "camera name '%s' is not valid (letters, digits and '_', starting with a "
            "letter); the driver does nothing",
            name.c_str());
        return;
      }
    }

    const int width = pnh.param("width", 320);
    const int height = pnh.param("height", 240);
    const double fps = pnh.param("fps", 25.0);
    if (width < 0 || height < 0 || !(fps > 0.0) || !std::isfinite(fps)) {
      NODELET_FATAL(
          "width %d, height %d, fps %g: need width, height >= 0 and fps > 0; the driver "
          "does nothing",
          width, height, fps);
      return;
    }
    SourceOptions options;
    options.width = width;
    options.height = height;
    options.fps = fps;
    options.fourcc = pnh.param<std::string>("fourcc", "");
    options.loop = pnh.param("loop", false);
    if (!options.fourcc.empty() && options.fourcc.size() != 4) {
      NODELET_WARN("fourcc '%s' ignored: a pixel format code has 4 characters",
                   options.fourcc.c_str());
      options.fourcc.clear();
    }
    const int max_failures =
        std::max(1, pnh.param("max_failures", static_cast<int>(std::ceil(fps))));

    // Open the sources; one that cannot be opened is reported and left out.
    std::vector<std::unique_ptr<FrameSource>> opened;
    for (int i = 0; i < count; ++i) {
      try {
        opened.push_back(openFrameSource(parseSourceSpec(sources[i]), options));
      } catch (const std::exception& e) {
        NODELET_ERROR("camera %s: %s; it will not publish (the other cameras still run)",
                      names[i].c_str(), e.what());
        opened.push_back(nullptr);
      }
    }
    capture_ =
        std::make_unique<MultiCapture>(names, std::move(opened), width, height, max_failures);
    reopen_ = pnh.param("reopen", true);
    if (reopen_) {
      ReopenBackoff backoff;
      backoff.first_delay = pnh.param("reopen_first_delay", backoff.first_delay);
      backoff.max_delay = pnh.param("reopen_max_delay", backoff.max_delay);
      std::vector<SourceSpec> specs;
      for (const std::string& source : sources) {
        try {
          specs.push_back(parseSourceSpec(source));
        } catch (const std::exception&) {
          specs.emplace_back();  // not a source: every attempt fails like the first, with backoff
          specs.back().text = source;
        }
      }
      capture_->enableReopen(
          std::move(specs),
          [options](const SourceSpec& spec) { return openFrameSource(spec, options); }, backoff);
    }

    const std::optional<CameraRig> rig = loadRig(pnh.param<std::string>("rig_file", ""));

    std::unique_lock<std::mutex> plugins(imageTransportMutex());
    image_transport::ImageTransport it(nh);
    outputs_.resize(count);
    for (int i = 0; i < count; ++i) {
      Output& out = outputs_[i];
      out.name = names[i];
      out.frame_id = opticalFrame(names[i]);
      out.publisher = it.advertiseCamera(names[i] + "/image_raw", 2);
      out.info_manager = std::make_unique<camera_info_manager::CameraInfoManager>(
          ros::NodeHandle(nh, names[i]), names[i], urls[i]);
      const std::string calibration = setUpCalibration(&out, urls[i], rig);
      NODELET_INFO("camera %s: source '%s' -> %s, camera_info from %s", names[i].c_str(),
                   sources[i].c_str(), out.publisher.getTopic().c_str(), calibration.c_str());
    }
    plugins.unlock();
    if (rig) publishExtrinsics(*rig);

    if (capture_->runningCount() == 0) {
      if (!reopen_) {
        NODELET_ERROR("no camera could be opened: nothing to publish");
        return;
      }
      NODELET_ERROR("no camera could be opened yet: trying again (parameter reopen)");
    }
    NODELET_INFO("capturing %d of %d cameras at %g fps, %dx%d", capture_->runningCount(), count,
                 fps, width, height);
    timer_ = nh.createSteadyTimer(ros::WallDuration(1.0 / fps),
                                  [this](const ros::SteadyTimerEvent&) { captureSet(); });
  }

  // A list parameter of strings (numbers are taken as their text). Absent = empty, true.
  bool readStringList(const ros::NodeHandle& pnh, const std::string& key,
                      std::vector<std::string>* out) {
    out->clear();
    XmlRpc::XmlRpcValue value;
    if (!pnh.getParam(key, value)) return true;
    if (value.getType() != XmlRpc::XmlRpcValue::TypeArray) {
      NODELET_FATAL("parameter ~%s must be a list; the driver does nothing", key.c_str());
      return false;
    }
    for (int i = 0; i < value.size(); ++i) {
      XmlRpc::XmlRpcValue& item = value[i];
      switch (item.getType()) {
        case XmlRpc::XmlRpcValue::TypeString:
          out->push_back(static_cast<std::string>(item));
          break;
        case XmlRpc::XmlRpcValue::TypeInt:
          out->push_back(std::to_string(static_cast<int>(item)));
          break;
        default:
          NODELET_FATAL(
              "parameter ~%s: entry %d is neither a string nor an integer; the driver "
              "does nothing",
              key.c_str(), i);
          return false;
      }
    }
    return true;
  }

  static bool validCameraName(const std::string& name) {
    if (name.empty() || !std::isalpha(static_cast<unsigned char>(name[0]))) return false;
    return std::all_of(name.begin(), name.end(),
                       [](unsigned char c) { return std::isalnum(c) || c == '_'; });
  }

  std::optional<CameraRig> loadRig(const std::string& rig_file) {
    if (rig_file.empty()) return std::nullopt;
    try {
      return loadCameraRig(rig_file);
    } catch (const std::exception& e) {
      NODELET_ERROR("rig_file: %s; no extrinsics published", e.what());
      return std::nullopt;
    }
  }

  static const Camera* findCamera(const std::optional<CameraRig>& rig, const std::string& name) {
    if (!rig) return nullptr;
    for (const Camera& camera : rig->cameras) {
      if (camera.name == name) return &camera;
    }
    return nullptr;
  }

  // Loads the camera's calibration (url, else the rig's intrinsics, else camera_info_manager's
  // default url). Returns where it comes from, for the log.
  std::string setUpCalibration(Output* out, const std::string& url,
                               const std::optional<CameraRig>& rig) {
    camera_info_manager::CameraInfoManager& manager = *out->info_manager;
    if (!url.empty()) {
      if (!manager.validateURL(url)) {
        NODELET_ERROR(
            "camera %s: camera_info_url '%s' is not a valid url (file:// or "
            "package://); its camera_info is uncalibrated",
            out->name.c_str(), url.c_str());
      } else if (!manager.isCalibrated()) {  // loads it
        NODELET_ERROR(
            "camera %s: no calibration could be read from camera_info_url '%s'; its "
            "camera_info is uncalibrated",
            out->name.c_str(), url.c_str());
      }
      return "'" + url + "'";
    }
    if (const Camera* camera = findCamera(rig, out->name)) {
      manager.setCameraInfo(toCameraInfo(*camera));
      return "the rig file";
    }
    return manager.isCalibrated() ? "camera_info_manager's default url" : "nowhere (uncalibrated)";
  }

  void publishExtrinsics(const CameraRig& rig) {
    std::vector<geometry_msgs::TransformStamped> transforms;
    const ros::Time now = ros::Time::now();
    for (const Output& out : outputs_) {
      const Camera* camera = findCamera(rig, out.name);
      if (!camera) {
        NODELET_WARN("camera %s is not in the rig file: no extrinsics published for it",
                     out.name.c_str());
        continue;
      }
      geometry_msgs::TransformStamped transform;
      transform.header.stamp = now;
      transform.header.frame_id = rig.root_frame;
      transform.child_frame_id = out.frame_id;
      transform.transform = toTransformMsg(camera->world_to_camera.inverse());
      transforms.push_back(transform);
    }
    if (transforms.empty()) return;
    static_broadcaster_ = std::make_unique<tf2_ros::StaticTransformBroadcaster>();
    static_broadcaster_->sendTransform(transforms);
    NODELET_INFO("published the extrinsics of %zu cameras as static tf from '%s'",
                 transforms.size(), rig.root_frame.c_str());
  }

  void captureSet() {
    capture_->reopenDue(ros::SteadyTime::now().toSec());
    capture_->grabAll();
    // One stamp for the whole set, taken when every camera has latched its frame.
    std_msgs::Header header;
    header.stamp = ros::Time::now();
    const std::vector<cv::Mat> frames = capture_->retrieveAll();
    report(capture_->takeEvents());

    for (std::size_t i = 0; i < frames.size(); ++i) {
      if (frames[i].empty()) continue;
      Output& out = outputs_[i];
      header.frame_id = out.frame_id;
      auto image = boost::make_shared<sensor_msgs::Image>(toImageMsg(frames[i], header));
      auto info = boost::make_shared<sensor_msgs::CameraInfo>(out.info_manager->getCameraInfo());
      checkInfoSize(&out, info.get(), image->width, image->height);
      info->header = header;
      out.publisher.publish(image, info);
    }
    if (capture_->runningCount() == 0 && !anyCameraMayReturn()) {
      NODELET_ERROR("no camera is delivering any more: the driver stops capturing");
      timer_.stop();
    }
  }

  // A camera that stopped or was never opened comes back when reopening is on; a finished
  // file or folder does not.
  bool anyCameraMayReturn() const {
    if (!reopen_) return false;
    for (int i = 0; i < capture_->size(); ++i) {
      if (capture_->state(i) != CameraState::kFinished) return true;
    }
    return false;
  }

  void checkInfoSize(Output* out, sensor_msgs::CameraInfo* info, std::uint32_t width,
                     std::uint32_t height) {
    if (info->width == 0 || info->height == 0) {  // uncalibrated: at least give the size
      info->width = width;
      info->height = height;
      if (!out->uncalibrated_warned) {
        out->uncalibrated_warned = true;
        NODELET_WARN("camera %s is not calibrated: its camera_info has no intrinsics",
                     out->name.c_str());
      }
      return;
    }
    if (info->width == width && info->height == height) return;
    // The frames were resized to width x height (or the calibration is for another mode):
    // rescale the intrinsics so that they describe the published images.
    const double aspect_in = static_cast<double>(info->width) / std::max(1u, info->height);
    const double aspect_out = static_cast<double>(width) / std::max(1u, height);
    if (std::abs(aspect_in / aspect_out - 1.0) > 0.01 && !out->info_size_warned) {
      out->info_size_warned = true;
      NODELET_WARN(
          "camera %s: camera_info is for %ux%u images but the images are %ux%u, another aspect "
          "ratio: rescaled anyway, but check that the calibration is for this camera mode",
          out->name.c_str(), info->width, info->height, width, height);
    }
    ImageIntrinsics intrinsics;
    intrinsics.width = static_cast<int>(info->width);
    intrinsics.height = static_cast<int>(info->height);
    std::copy(info->K.begin(), info->K.end(), intrinsics.K.begin());
    std::copy(info->P.begin(), info->P.end(), intrinsics.P.begin());
    const ImageIntrinsics scaled =
        scaleIntrinsics(intrinsics, static_cast<int>(width), static_cast<int>(height));
    std::copy(scaled.K.begin(), scaled.K.end(), info->K.begin());
    std::copy(scaled.P.begin(), scaled.P.end(), info->P.begin());
    const double sx = static_cast<double>(width) / info->width;
    const double sy = static_cast<double>(height) / info->height;
    if (info->roi.width != 0 && info->roi.height != 0) {
      info->roi.x_offset = static_cast<std::uint32_t>(std::lround(info->roi.x_offset * sx));
      info->roi.y_offset = static_cast<std::uint32_t>(std::lround(info->roi.y_offset * sy));
      info->roi.width = static_cast<std::uint32_t>(std::lround(info->roi.width * sx));
      info->roi.height = static_cast<std::uint32_t>(std::lround(info->roi.height * sy));
    }
    if (!out->info_scaled_logged) {
      out->info_scaled_logged = true;
      NODELET_INFO(
          "camera %s: camera_info calibrated at %ux%u, rescaled (K, P) to the %ux%u "
          "images",
          out->name.c_str(), info->width, info->height, width, height);
    }
    info->width = width;
    info->height = height;
  }

  void report(const std::vector<CaptureEvent>& events) {
    for (const CaptureEvent& event : events) {
      switch (event.kind) {
        case CaptureEvent::Kind::kResized:
          NODELET_WARN("%s", event.message.c_str());
          break;
        case CaptureEvent::Kind::kReadFailed: {
          // Throttled per camera, so that one camera's failures do not hide another's.
          Output& out = outputs_.at(event.camera);
          const ros::WallTime now = ros::WallTime::now();
          if ((now - out.last_failure_warning).toSec() > 5.0) {
            out.last_failure_warning = now;
            NODELET_WARN("%s", event.message.c_str());
          }
          break;
        }
        case CaptureEvent::Kind::kReopenFailed:  // the backoff spaces them out
          NODELET_WARN("%s", event.message.c_str());
          break;
        case CaptureEvent::Kind::kReopened:
          NODELET_INFO("%s", event.message.c_str());
          break;
        case CaptureEvent::Kind::kStopped:
        case CaptureEvent::Kind::kFinished:
          NODELET_ERROR("%s", event.message.c_str());
          break;
      }
    }
  }

  std::vector<Output> outputs_;
  std::unique_ptr<MultiCapture> capture_;
  bool reopen_ = true;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> static_broadcaster_;
  ros::SteadyTimer timer_;  // last: stopped first on destruction
};

}  // namespace sag_hand_tracker

PLUGINLIB_EXPORT_CLASS(sag_hand_tracker::CameraDriverNodelet, nodelet::Nodelet)
