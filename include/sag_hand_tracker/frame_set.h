// A synchronized set of camera images (what the bag reader yields and the pipeline consumes) and
// what the pipeline makes of it.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "sag_hand_tracker/tracker.h"

namespace sag_hand_tracker {

// One camera's image of a set.
struct CameraImage {
  int camera = -1;  // index into the reader's (or the pipeline's) camera list
  cv::Mat rgb;      // CV_8UC3, RGB order
};

// The images that share one stamp. A camera that did not deliver is absent; `images` is sorted by
// camera index.
struct FrameSet {
  std::int64_t stamp_ns = 0;  // exact header stamp in nanoseconds
  std::vector<CameraImage> images;

  double stamp() const { return static_cast<double>(stamp_ns) * 1e-9; }
};

// The outcome of one set: either it went into the background plates (the first frames of a
// recording, without the hand), or it was segmented and tracked.
struct ProcessedFrame {
  bool background = false;  // true: learned as background, `result` holds no pose
  FrameResult result;
  int image_gaussians = 0;  // foreground image Gaussians over all cameras of the set
  double segmentation_seconds = 0.0;
  double tracking_seconds = 0.0;  // HandTracker::update (start or optimisation)
};

}  // namespace sag_hand_tracker
