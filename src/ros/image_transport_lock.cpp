#include "sag_hand_tracker/ros/image_transport_lock.h"

namespace sag_hand_tracker {

std::mutex& imageTransportMutex() {
  static std::mutex mutex;
  return mutex;
}

}  // namespace sag_hand_tracker
