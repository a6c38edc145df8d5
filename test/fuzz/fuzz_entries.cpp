#include "fuzz_entries.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <rosbag/bag.h>

#include "sag_hand_tracker/HandRegion.h"
#include "sag_hand_tracker/SumOfGaussians.h"
#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/ros/bag_input.h"
#include "sag_hand_tracker/ros/checked_subscription.h"
#include "sag_hand_tracker/ros/conversions.h"
#include "sag_hand_tracker/ros/sog_conversions.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_fuzz {
namespace {

using sag_hand_tracker::InputError;

// A finding: the input was accepted but gave a non-finite result.
[[noreturn]] void finding(const char* what) {
  std::fprintf(stderr, "fuzz finding: %s\n", what);
  std::abort();
}

std::string text(const std::uint8_t* data, std::size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

// Takes fixed-size values from the front of the input; zeros once it is used up.
class ByteReader {
 public:
  ByteReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  template <typename T>
  T take() {
    T value{};
    const std::size_t n = std::min(sizeof(T), size_ - used_);
    std::memcpy(&value, data_ + used_, n);
    used_ += n;
    return value;
  }
  std::string takeString(std::size_t max_size) {
    const std::size_t n =
        std::min<std::size_t>(take<std::uint8_t>() % (max_size + 1), size_ - used_);
    std::string s(reinterpret_cast<const char*>(data_ + used_), n);
    used_ += n;
    return s;
  }
  std::vector<std::uint8_t> rest() {
    std::vector<std::uint8_t> bytes(data_ + used_, data_ + size_);
    used_ = size_;
    return bytes;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t used_ = 0;
};

const sag_hand_tracker::HandModel& sagModel() {
  static const sag_hand_tracker::HandModel model =
      sag_hand_tracker::loadHandModel(std::string(SAG_SOURCE_DIR) + "/config/hand_sag_right.yaml");
  return model;
}

void checkCamera(const sag_hand_tracker::Camera& camera) {
  sag_hand_tracker::validateCamera(camera);
  const Eigen::Vector2d centre(0.5 * camera.width, 0.5 * camera.height);
  if (!camera.undistortPixel(centre).allFinite()) {
    // OpenCV's iterative undistortion may leave the image for wild coefficients; it must not
    // become NaN for a camera we accepted.
    finding("undistortPixel of an accepted camera is not finite");
  }
}

}  // namespace

void fuzzModelYaml(const std::uint8_t* data, std::size_t size) {
  try {
    const sag_hand_tracker::HandModel model =
        sag_hand_tracker::parseHandModel(text(data, size), "fuzz");
    const sag_hand_tracker::HandModel mirrored = sag_hand_tracker::mirrorHandModel(model);
    for (const auto& tip : sag_hand_tracker::fingertips(mirrored, sag_hand_tracker::Pose())) {
      if (!tip.allFinite()) finding("fingertip of an accepted model is not finite");
    }
  } catch (const InputError&) {
  }
}

void fuzzRigYaml(const std::uint8_t* data, std::size_t size) {
  const std::string all = text(data, size);
  const std::size_t split = all.find("\n%%\n");
  const std::string rig_text = split == std::string::npos ? all : all.substr(0, split);
  const std::string camera_text = split == std::string::npos ? "" : all.substr(split + 4);
  try {
    checkCamera(sag_hand_tracker::parseCameraCalibration(camera_text, "fuzz-camera"));
  } catch (const InputError&) {
  }
  try {
    const sag_hand_tracker::CameraRig rig =
        sag_hand_tracker::parseCameraRig(rig_text, "fuzz-rig", [&](const std::string&) {
          return sag_hand_tracker::parseCameraCalibration(camera_text, "fuzz-camera");
        });
    for (const sag_hand_tracker::Camera& camera : rig.cameras) checkCamera(camera);
  } catch (const InputError&) {
  }
}

void fuzzMotionYaml(const std::uint8_t* data, std::size_t size) {
  try {
    const sag_hand_tracker::studio::Motion motion =
        sag_hand_tracker::studio::parseMotion(text(data, size), "fuzz", sagModel(), 1);
    for (int k = 0; k <= 8; ++k) {
      if (!motion.poseAt(motion.duration * k / 8.0).allFinite()) {
        finding("pose of an accepted motion is not finite");
      }
    }
  } catch (const InputError&) {
  }
}

void fuzzBag(const std::uint8_t* data, std::size_t size) {
  // One rosbag::Bag for every input, opened and closed by each reader: making and destroying one
  // per input was 4/5 of an execution (pluginlib running rospack to find encryptor plugins, and
  // rosbag's 1 MB lz4 buffer mapped and unmapped by ASan). It also keeps rosbag's encryptor
  // plugin library loaded (loading and unloading it was once 9/10), as in a tool.
  static rosbag::Bag bag;
  // rosbag reads only files: the input goes to one in memory (tmpfs) where there is one.
  static const std::string path =
      std::string(std::filesystem::is_directory("/dev/shm") ? "/dev/shm" : "/tmp") +
      "/sag_fuzz_bag_" + std::to_string(::getpid()) + ".bag";
  {
    std::ofstream file(path, std::ios::binary | std::ios::trunc);
    file.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    sag_hand_tracker::BagReader reader(path, bag);
    sag_hand_tracker::FrameSet set;
    while (reader.next(&set)) {
    }
  } catch (const InputError&) {
  }
  std::remove(path.c_str());
}

void fuzzMessages(const std::uint8_t* data, std::size_t size) {
  ByteReader in(data, size);
  const int kind = in.take<std::uint8_t>() % 3;
  try {
    if (kind == 0) {
      sag_hand_tracker::SumOfGaussians msg;
      msg.width = in.take<std::uint32_t>();
      msg.height = in.take<std::uint32_t>();
      msg.gaussians.resize(in.take<std::uint16_t>() % 512);
      for (auto& g : msg.gaussians) {
        g.x = in.take<float>();
        g.y = in.take<float>();
        g.sigma = in.take<float>();
        g.h = in.take<float>();
        g.s = in.take<float>();
        g.v = in.take<float>();
      }
      const sag_hand_tracker::ImageSoG sog = sag_hand_tracker::sogFromMsg(msg);
      for (const auto& g : sog.gaussians) {
        if (!g.mean.allFinite() || !std::isfinite(g.sigma)) finding("accepted SoG not finite");
      }
    } else if (kind == 1) {
      sensor_msgs::CameraInfo info;
      info.header.frame_id = in.takeString(32);
      info.width = in.take<std::uint32_t>();
      info.height = in.take<std::uint32_t>();
      static const char* const models[] = {"", "plumb_bob", "rational_polynomial", "equidistant"};
      const std::uint8_t model = in.take<std::uint8_t>();
      info.distortion_model = model < 4 ? models[model] : in.takeString(24);
      info.D.resize(in.take<std::uint8_t>() % 16);
      for (double& d : info.D) d = in.take<double>();
      for (double& k : info.K) k = in.take<double>();
      for (double& r : info.R) r = in.take<double>();
      for (double& p : info.P) p = in.take<double>();
      info.binning_x = in.take<std::uint8_t>() % 3;
      info.binning_y = in.take<std::uint8_t>() % 3;
      checkCamera(sag_hand_tracker::fromCameraInfo(info, in.takeString(16)));
    } else {
      sensor_msgs::Image image;
      image.width = in.take<std::uint32_t>();
      image.height = in.take<std::uint32_t>();
      static const char* const encodings[] = {"rgb8", "bgr8", "mono8", "rgba8"};
      const std::uint8_t encoding = in.take<std::uint8_t>();
      image.encoding = encoding < 4 ? encodings[encoding] : in.takeString(16);
      image.step = in.take<std::uint32_t>();
      image.data = in.rest();
      const cv::Mat rgb = sag_hand_tracker::toRgbMat(image);
      if (rgb.cols != static_cast<int>(image.width) || rgb.rows != static_cast<int>(image.height)) {
        finding("toRgbMat changed the image size");
      }
    }
  } catch (const InputError&) {
  }
}

namespace {

// The bytes through the live subscription's helper, as roscpp's transport hands them over; the
// message it accepts, or null.
template <class M>
boost::shared_ptr<const M> deserializeLive(const std::vector<std::uint8_t>& bytes) {
  int calls = 0;
  sag_hand_tracker::CheckedCallbackHelper<M> helper(
      [&calls](const boost::shared_ptr<const M>&) { ++calls; }, [](const std::string&) {});
  std::vector<std::uint8_t> buffer = bytes;  // roscpp's own, writable buffer
  ros::SubscriptionCallbackHelperDeserializeParams params;
  params.buffer = buffer.data();
  params.length = static_cast<std::uint32_t>(buffer.size());
  const ros::VoidConstPtr message = helper.deserialize(params);
  if (calls != 0) finding("the check called the callback");
  return boost::static_pointer_cast<const M>(message);
}

}  // namespace

void fuzzLiveMessages(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return;
  const int kind = data[0] % 3;
  const std::vector<std::uint8_t> bytes(data + 1, data + size);
  try {
    if (kind == 0) {
      const auto msg = deserializeLive<sag_hand_tracker::SumOfGaussians>(bytes);
      if (!msg) return;
      const sag_hand_tracker::ImageSoG sog = sag_hand_tracker::sogFromMsg(*msg);
      for (const auto& g : sog.gaussians) {
        if (!g.mean.allFinite() || !std::isfinite(g.sigma)) finding("accepted SoG not finite");
      }
      // The hand candidates the tracker's multi-view check reads (room cues): every accepted cell
      // in the image, the moving cells as many as `moving` or none.
      for (const sag_hand_tracker::HandCandidate& c : sag_hand_tracker::candidatesFromMsg(*msg)) {
        if (!c.centroid.allFinite() || !std::isfinite(c.score)) {
          finding("accepted candidate not finite");
        }
        if (c.moving < 0) finding("accepted candidate with a negative number of moving cells");
        const int image_cells = ((sog.width + c.cell_size - 1) / c.cell_size) *
                                ((sog.height + c.cell_size - 1) / c.cell_size);
        for (const std::vector<int>* indices : {&c.cell_indices, &c.moving_cell_indices}) {
          for (const int i : *indices) {
            if (i < 0 || i >= image_cells) finding("accepted candidate cell outside the image");
          }
        }
        if (!c.moving_cell_indices.empty() &&
            c.moving_cell_indices.size() != static_cast<size_t>(c.moving)) {
          finding("accepted candidate's moving cells not `moving` of them");
        }
      }
    } else if (kind == 1) {
      const auto info = deserializeLive<sensor_msgs::CameraInfo>(bytes);
      if (info) checkCamera(sag_hand_tracker::fromCameraInfo(*info, "cam0"));
    } else {
      deserializeLive<sag_hand_tracker::HandRegion>(bytes);
    }
  } catch (const InputError&) {
  } catch (const ros::serialization::StreamOverrunException&) {
    finding("a message the check accepted overran roscpp's deserializer");
  }
}

const std::vector<FuzzTarget>& fuzzTargets() {
  static const std::vector<FuzzTarget> targets{
      {"model_yaml", fuzzModelYaml},   {"rig_yaml", fuzzRigYaml},
      {"motion_yaml", fuzzMotionYaml}, {"bag", fuzzBag},
      {"messages", fuzzMessages},      {"live_messages", fuzzLiveMessages}};
  return targets;
}

}  // namespace sag_fuzz
