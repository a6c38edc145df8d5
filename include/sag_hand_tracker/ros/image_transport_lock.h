// One lock for image_transport calls that load or unload its plugins (issue 12, the soak): all
// nodelets of a manager share the process, and pluginlib/class_loader are not safe when two
// threads load and unload plugin libraries at once. A soak run crashed in _dl_close: a
// segmentation nodelet's lazy subscription (a timer thread) looked up the raw subscriber plugin
// while the tracker nodelet's onInit (the manager's loader thread) advertised its overlays.
#pragma once

#include <mutex>

namespace sag_hand_tracker {

// Held around ImageTransport construction, advertise, subscribe and shutdown in every nodelet of
// this package (one instance per process: it lives in libsag_ros).
std::mutex& imageTransportMutex();

}  // namespace sag_hand_tracker
