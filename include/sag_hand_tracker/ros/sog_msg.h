// The ImageSoG / ImageGaussian messages under names that do not clash with the core structs.
//
// msg/ImageSoG.msg generates `sag_hand_tracker::ImageSoG` (a typedef of ImageSoG_<...>), the same
// name as the core's `struct sag_hand_tracker::ImageSoG` (types.h); likewise ImageGaussian. A file
// that needs both includes this header (before any other include of the generated headers) and
// uses `sag_hand_tracker::ImageSoGMsg` / `ImageGaussianMsg` (and `ImageSoGMsg::ConstPtr`). The
// renaming only affects the typedef tokens; the wire type stays "sag_hand_tracker/ImageSoG".
#pragma once

#ifdef SAG_HAND_TRACKER_MESSAGE_IMAGESOG_H
#error "sag_hand_tracker/ImageSoG.h was included before sag_hand_tracker/ros/sog_msg.h"
#endif

#define ImageSoG ImageSoGMsg
#define ImageGaussian ImageGaussianMsg
#include "sag_hand_tracker/ImageSoG.h"
#undef ImageSoG
#undef ImageGaussian
