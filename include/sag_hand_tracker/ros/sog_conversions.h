// Message <-> core conversions for the image SoG (ROS layer; used by the nodelets and the graph
// tests). Camera, image and transform conversions are in conversions.h.
#pragma once

#include "sag_hand_tracker/SumOfGaussians.h"
#include "sag_hand_tracker/util/types.h"
#include "sag_hand_tracker/util/input_limits.h"

namespace sag_hand_tracker {

// Core image SoG from the message (raw pixels). Throws InputError naming the first non-finite or
// negative value, or a size or Gaussian count over the limits (input_limits.h).
ImageSoG sogFromMsg(const sag_hand_tracker::SumOfGaussians& msg);

sag_hand_tracker::SumOfGaussians sogToMsg(const ImageSoG& sog);

}  // namespace sag_hand_tracker
