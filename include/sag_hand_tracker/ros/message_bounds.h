// Serialized ROS messages checked before roscpp deserializes them (issue 12, fuzzing): roscpp
// resizes a vector or string to the length its prefix declares before it notices that the message
// is shorter, so one corrupt length in a bag (a CameraInfo declaring 1.8e9 distortion
// coefficients) makes it allocate gigabytes. Every variable-length field must fit in the bytes
// that follow its prefix; the walk follows the type's full message definition (the text rosbag
// stores with each connection and ros::message_traits gives), so it serves every message type.
#pragma once

#include <boost/make_shared.hpp>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <ros/message_traits.h>
#include <ros/serialization.h>
#include <rosbag/message_instance.h>

namespace sag_hand_tracker {

// "" when the `size` bytes at `data` are a message of type `datatype` ("pkg/Type") whose full
// definition (the type's fields first, then "MSG: pkg/Type" sections) is `definition`, with every
// length prefix within the bytes; else the first problem, naming the field ("D: 1800000000
// elements of 8 bytes declared, 40 bytes left"). Bytes left over at the end are a problem too;
// a type the definition does not define is reported as such.
std::string checkSerializedMessage(const std::string& datatype, const std::string& definition,
                                   const std::uint8_t* data, std::size_t size);

// rosbag::MessageInstance::instantiate<M>(), with the message's bytes checked first: null when
// the connection's type is not M (as instantiate); throws std::runtime_error with the problem when
// the bytes are not a well-formed M.
template <class M>
boost::shared_ptr<M> instantiateChecked(const rosbag::MessageInstance& message) {
  if (message.getDataType() != ros::message_traits::datatype<M>()) return nullptr;
  if (message.getMD5Sum() != "*" && message.getMD5Sum() != ros::message_traits::md5sum<M>()) {
    return nullptr;
  }
  std::vector<std::uint8_t> bytes(message.size());
  ros::serialization::OStream out(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  message.write(out);
  const std::string problem =
      checkSerializedMessage(ros::message_traits::datatype<M>(),
                             ros::message_traits::definition<M>(), bytes.data(), bytes.size());
  if (!problem.empty()) {
    throw std::runtime_error("malformed " + message.getDataType() + " message (" + problem + ")");
  }
  boost::shared_ptr<M> result = boost::make_shared<M>();
  ros::serialization::IStream in(bytes.data(), static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::deserialize(in, *result);
  return result;
}

}  // namespace sag_hand_tracker
