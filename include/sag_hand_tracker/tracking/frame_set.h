// A synchronized set of camera images: what the bag reader yields and the pipeline consumes.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

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

}  // namespace sag_hand_tracker
