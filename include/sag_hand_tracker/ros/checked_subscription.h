// Live subscriptions whose serialized messages are checked before roscpp deserializes them
// (issue 12): a message from another process whose length prefix declares more elements than it
// carries (1.8e9 distortion coefficients) makes roscpp's deserializer allocate and clear what it
// declares before it notices, gigabytes that can take the whole nodelet manager down. The bytes
// are walked first (ros/message_bounds.h, the same check as every bag read); a malformed message
// is dropped and reported, the rest keeps running. Messages from the same process (nodelets in
// one manager) are passed as objects, never serialized, so they cost nothing here.
#pragma once

#include <ros/node_handle.h>
#include <ros/subscribe_options.h>
#include <ros/subscription_callback_helper.h>

#include <boost/make_shared.hpp>
#include <cstdint>
#include <functional>
#include <string>

#include "sag_hand_tracker/ros/message_bounds.h"

namespace sag_hand_tracker {

// roscpp's helper for `const boost::shared_ptr<const M>&` callbacks, with the check before its
// deserialize. `on_malformed` gets the problem (the field, its declared and available bytes);
// the message is then dropped (roscpp skips a message whose deserialization gives none).
template <class M>
class CheckedCallbackHelper
    : public ros::SubscriptionCallbackHelperT<const boost::shared_ptr<const M>&> {
 public:
  using Base = ros::SubscriptionCallbackHelperT<const boost::shared_ptr<const M>&>;

  CheckedCallbackHelper(const typename Base::Callback& callback,
                        std::function<void(const std::string&)> on_malformed)
      : Base(callback), on_malformed_(std::move(on_malformed)) {}

  ros::VoidConstPtr deserialize(
      const ros::SubscriptionCallbackHelperDeserializeParams& params) override {
    const std::string problem =
        checkSerializedMessage(ros::message_traits::datatype<M>(),
                               ros::message_traits::definition<M>(), params.buffer, params.length);
    if (!problem.empty()) {
      if (on_malformed_) on_malformed_(problem);
      return ros::VoidConstPtr();
    }
    return Base::deserialize(params);
  }

 private:
  std::function<void(const std::string&)> on_malformed_;
};

// nh.subscribe<M>(topic, queue_size, callback), with every message from another process checked.
template <class M>
ros::Subscriber subscribeChecked(
    ros::NodeHandle& nh, const std::string& topic, std::uint32_t queue_size,
    const std::function<void(const boost::shared_ptr<const M>&)>& callback,
    std::function<void(const std::string&)> on_malformed) {
  ros::SubscribeOptions options;
  options.template init<M>(topic, queue_size, callback);
  options.helper = boost::make_shared<CheckedCallbackHelper<M>>(callback, std::move(on_malformed));
  return nh.subscribe(options);
}

}  // namespace sag_hand_tracker
