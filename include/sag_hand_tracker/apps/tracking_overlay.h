// Pictures of what an offline track did (track_bag --overlay-dir): for chosen sets, every camera's
// image with the segmentation's foreground and the tracked model drawn over it, one PNG per set.
// What a table of fingertip errors cannot show (a finger laid along its neighbour, a hand turned
// about its own axis, a start on the table) is seen at a glance here.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/tracking/frame_set.h"
#include "sag_hand_tracker/tracking/tracker.h"

namespace sag_hand_tracker {

// One RGB sheet of a set: a header line (frame number, stamp, status, energy), then a tile per
// image of `set` (up to three per row, in the set's order, each at the first image's size): the
// image dimmed where `foregrounds[camera]` (CV_8UC1, the segmentation's mask; empty: not dimmed)
// is zero, the camera's name, and with a pose the model's Gaussians as 1-sigma ellipses and its
// fingertips (drawModelOverlay). `cameras` is indexed by CameraImage::camera; `model` is the
// tracker's at the time of the set (its size). Throws InputError for an image whose camera index
// is out of range.
cv::Mat trackingOverlaySheet(const FrameSet& set, const std::vector<Camera>& cameras,
                             const std::vector<cv::Mat>& foregrounds, const HandModel& model,
                             const FrameResult& result, long frame_number);

// Pastes `tile` (RGB) into `sheet` at `where`: resized to its size if it differs, `label` written
// at its top left in white on the sheet (`tile` itself is not drawn on). The one tile step of
// trackingOverlaySheet and calibrate_hand's contact sheet.
void pasteSheetTile(const cv::Mat& tile, const std::string& label, const cv::Rect& where,
                    cv::Mat* sheet);

// Which sets get a sheet: every `every`-th set with the hand's tracking under way (counted from the
// first set after the background), a track's start or restart, and the first frame of each lost
// stretch.
class OverlaySchedule {
 public:
  explicit OverlaySchedule(int every) : every_(every) {}
  // Called once per set after the background, in order.
  bool wants(const FrameResult& result);

 private:
  int every_;
  long count_ = 0;
  bool was_lost_ = false;
};

// Makes `dir` (and its parents) if it does not exist. Throws InputError, naming `option`, when it
// is not a folder, cannot be made, or already holds anything: the sheets never replace a file.
void prepareOverlayDir(const std::string& dir, const std::string& option);

// DIR/frame_<number, 6 digits>.png.
std::string overlayPath(const std::string& dir, long frame_number);

}  // namespace sag_hand_tracker
