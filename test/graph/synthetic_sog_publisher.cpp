// Test input for the tracker graph: a synthetic five-camera rig (test_support/synthetic_scene.h)
// and a slowly moving hand, published like the segmentation nodelets would: static tf of the
// optical frames, cam<i>/camera_info and cam<i>/sog, one stamp per set, plus the ground truth
// fingertips on ground_truth/fingertips.
// Private parameters:
//   rate (15 Hz), num_cameras (5), duration (0 = forever)
//   drop_cameras (list of indices) and drop_after (s): those cameras stop publishing then;
//     drop_times (list of s, one per drop_cameras entry) gives each camera its own time instead;
//     resume_times (list of s, one per drop_cameras entry) makes it publish again from then
//   malformed (false): cam<last> sends malformed SoGs in turn (size not matching camera_info,
//     a NaN Gaussian, no Gaussians at all, an unknown frame, bytes whose Gaussian array declares
//     1e9 elements) and cam<last-1> never sends its camera_info.
#include "sag_hand_tracker/SumOfGaussians.h"

#include <geometry_msgs/PoseArray.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <stdexcept>

#include "sag_hand_tracker/ros/conversions.h"
#include "sag_hand_tracker/ros/sog_conversions.h"
#include "test_support/synthetic_scene.h"

using namespace sag_hand_tracker;

// Bytes published as a SumOfGaussians, whatever they hold: how a broken or hostile publisher in
// another process reaches the tracker (roscpp checks only the type's name and MD5).
struct RawSoG {
  std::vector<std::uint8_t> bytes;
};
namespace ros {
namespace message_traits {
template <>
struct MD5Sum<RawSoG> {
  static const char* value() { return MD5Sum<SumOfGaussians>::value(); }
  static const char* value(const RawSoG&) { return value(); }
};
template <>
struct DataType<RawSoG> {
  static const char* value() { return DataType<SumOfGaussians>::value(); }
  static const char* value(const RawSoG&) { return value(); }
};
template <>
struct Definition<RawSoG> {
  static const char* value() { return Definition<SumOfGaussians>::value(); }
  static const char* value(const RawSoG&) { return value(); }
};
}  // namespace message_traits
namespace serialization {
template <>
struct Serializer<RawSoG> {
  template <typename Stream>
  inline static void write(Stream& stream, const RawSoG& raw) {
    std::memcpy(stream.advance(raw.bytes.size()), raw.bytes.data(), raw.bytes.size());
  }
  inline static std::uint32_t serializedLength(const RawSoG& raw) { return raw.bytes.size(); }
};
}  // namespace serialization
}  // namespace ros

namespace {

// `msg` serialized, with its Gaussian array's length prefix replaced by 1e9.
RawSoG withHugeGaussianCount(const SumOfGaussians& msg) {
  RawSoG raw;
  raw.bytes.resize(ros::serialization::serializationLength(msg));
  ros::serialization::OStream out(raw.bytes.data(), raw.bytes.size());
  ros::serialization::serialize(out, msg);
  // The prefix is the first 4 bytes of the serialized `gaussians` field: find it by serializing
  // the message without its Gaussians, whose prefix then sits at the same place (the fields
  // before it are the same).
  SumOfGaussians head = msg;
  head.gaussians.clear();
  std::vector<std::uint8_t> head_bytes(ros::serialization::serializationLength(head));
  ros::serialization::OStream head_out(head_bytes.data(), head_bytes.size());
  ros::serialization::serialize(head_out, head);
  for (std::size_t offset = 0; offset + 4 <= head_bytes.size(); ++offset) {
    std::uint32_t value = 0, original = 0;
    std::memcpy(&value, head_bytes.data() + offset, 4);
    std::memcpy(&original, raw.bytes.data() + offset, 4);
    if (value == 0 && original == msg.gaussians.size()) {
      const std::uint32_t huge = 1000000000u;
      std::memcpy(raw.bytes.data() + offset, &huge, 4);
      return raw;
    }
  }
  throw std::runtime_error("the Gaussians' length prefix was not found");
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "synthetic_sog_publisher");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  const double rate = pnh.param("rate", 15.0);
  const double duration = pnh.param("duration", 0.0);
  const double drop_after = pnh.param("drop_after", 1e9);
  const bool malformed = pnh.param("malformed", false);
  std::vector<int> drop_list;
  pnh.getParam("drop_cameras", drop_list);
  std::vector<double> drop_times;
  pnh.getParam("drop_times", drop_times);
  std::vector<double> resume_times;
  pnh.getParam("resume_times", resume_times);
  std::map<int, double> drop;    // camera -> time it stops
  std::map<int, double> resume;  // camera -> time it publishes again
  for (size_t k = 0; k < drop_list.size(); ++k) {
    drop[drop_list[k]] = k < drop_times.size() ? drop_times[k] : drop_after;
    resume[drop_list[k]] = k < resume_times.size() ? resume_times[k] : 1e18;
  }

  const HandModel model = loadHandModel(sag_test::modelPath("sag"));
  std::vector<Camera> cameras = sag_test::fiveCameraRig();
  const int n = std::min<int>(pnh.param("num_cameras", 5), cameras.size());
  cameras.resize(n);

  tf2_ros::StaticTransformBroadcaster static_tf;
  std::vector<geometry_msgs::TransformStamped> transforms;
  std::vector<ros::Publisher> sog_pubs, info_pubs;
  ros::Publisher raw_pub;  // malformed: the raw bytes on cam<last>/sog
  for (int i = 0; i < n; ++i) {
    const Eigen::Isometry3d camera_to_world = cameras[i].world_to_camera.inverse();
    const Eigen::Quaterniond q(camera_to_world.rotation());
    geometry_msgs::TransformStamped t;
    t.header.stamp = ros::Time::now();
    t.header.frame_id = "world";
    t.child_frame_id = "cam" + std::to_string(i) + "_optical_frame";
    t.transform.translation.x = camera_to_world.translation().x();
    t.transform.translation.y = camera_to_world.translation().y();
    t.transform.translation.z = camera_to_world.translation().z();
    t.transform.rotation.x = q.x();
    t.transform.rotation.y = q.y();
    t.transform.rotation.z = q.z();
    t.transform.rotation.w = q.w();
    transforms.push_back(t);
    sog_pubs.push_back(nh.advertise<SumOfGaussians>("cam" + std::to_string(i) + "/sog", 5));
    info_pubs.push_back(
        nh.advertise<sensor_msgs::CameraInfo>("cam" + std::to_string(i) + "/camera_info", 5));
  }
  if (malformed) raw_pub = nh.advertise<RawSoG>("cam" + std::to_string(n - 1) + "/sog", 5);
  static_tf.sendTransform(transforms);
  ros::Publisher truth_pub = nh.advertise<geometry_msgs::PoseArray>("ground_truth/fingertips", 10);

  ros::Duration(1.0).sleep();  // let the graph connect
  const ros::Time start = ros::Time::now();
  ros::Rate loop(rate);
  long frame = 0;
  while (ros::ok()) {
    const ros::Time stamp = ros::Time::now();
    const double t = (stamp - start).toSec();
    if (duration > 0 && t > duration) break;
    // Slow motion: the wrist sways 2 cm, the fingers flex a little.
    Pose pose = sag_test::typicalPose(model);
    pose.translation.x() += 0.02 * std::sin(2 * M_PI * 0.2 * t);
    pose.translation.y() += 0.01 * std::sin(2 * M_PI * 0.13 * t);
    for (int j = 0; j < kNumJointDof; ++j) {
      const double range = model.joints[j].max - model.joints[j].min;
      pose.joints[j] += 0.1 * range * std::sin(2 * M_PI * 0.25 * t);
    }
    clampToLimits(model, &pose);

    for (int i = 0; i < n; ++i) {
      if (drop.count(i) && t > drop.at(i) && t < resume.at(i)) continue;
      const std::string frame_id = "cam" + std::to_string(i) + "_optical_frame";
      const bool broken_info = malformed && i == n - 2;
      const bool broken_sog = malformed && i == n - 1;
      if (!broken_info) {
        sensor_msgs::CameraInfo info;
        info.header.stamp = stamp;
        info.header.frame_id = frame_id;
        info.width = cameras[i].width;
        info.height = cameras[i].height;
        info.distortion_model = "plumb_bob";
        info.D.assign(5, 0.0);
        for (int k = 0; k < 9; ++k) info.K[k] = cameras[i].K(k / 3, k % 3);
        info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        for (int r = 0; r < 3; ++r)
          for (int c = 0; c < 3; ++c) info.P[r * 4 + c] = cameras[i].K(r, c);
        info_pubs[i].publish(info);
      }
      SumOfGaussians msg = sogToMsg(sag_test::modelImageSoG(model, pose, cameras[i]));
      msg.header.stamp = stamp;
      msg.header.frame_id = frame_id;
      if (broken_sog) {
        switch (frame % 5) {
          case 0:
            msg.width /= 2;
            break;  // size does not match camera_info
          case 1:
            if (!msg.gaussians.empty())
              msg.gaussians[0].x = std::numeric_limits<float>::quiet_NaN();
            break;
          case 2:
            msg.gaussians.clear();
            break;  // an empty SoG
          case 3:
            msg.header.frame_id = "no_such_frame";
            break;
          default:
            if (!msg.gaussians.empty()) {
              raw_pub.publish(withHugeGaussianCount(msg));
              continue;
            }
            break;
        }
      }
      sog_pubs[i].publish(msg);
    }
    std_msgs::Header truth_header;
    truth_header.stamp = stamp;
    truth_header.frame_id = "world";
    truth_pub.publish(toFingertipsMsg(fingertips(model, pose), truth_header));
    ++frame;
    loop.sleep();
  }
  return 0;
}
