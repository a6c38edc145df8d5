#include "sag_hand_tracker/apps/tracking_overlay.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <opencv2/imgproc.hpp>

#include "sag_hand_tracker/fitting/hand_fit.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

constexpr int kColumns = 3;
constexpr int kHeaderPixels = 22;
// What the background keeps of its brightness: the foreground stands out, the room stays readable.
constexpr double kBackgroundShade = 0.4;

std::string headerText(const FrameResult& result, long frame_number) {
  char text[160];
  if (result.has_pose) {
    std::snprintf(text, sizeof(text), "frame %ld  stamp %.3f  %s  E %.4f", frame_number,
                  result.stamp, toString(result.status).c_str(), result.energy.total);
  } else {
    std::snprintf(text, sizeof(text), "frame %ld  stamp %.3f  %s (no pose)", frame_number,
                  result.stamp, toString(result.status).c_str());
  }
  return text;
}

}  // namespace

cv::Mat trackingOverlaySheet(const FrameSet& set, const std::vector<Camera>& cameras,
                             const std::vector<cv::Mat>& foregrounds, const HandModel& model,
                             const FrameResult& result, long frame_number) {
  if (set.images.empty()) return cv::Mat();
  const int tile_w = set.images.front().rgb.cols, tile_h = set.images.front().rgb.rows;
  const int tiles = static_cast<int>(set.images.size());
  const int columns = std::min(kColumns, tiles);
  const int rows = (tiles + columns - 1) / columns;
  cv::Mat sheet(kHeaderPixels + rows * tile_h, columns * tile_w, CV_8UC3, cv::Scalar::all(255));
  cv::putText(sheet, headerText(result, frame_number), cv::Point(5, 16), cv::FONT_HERSHEY_SIMPLEX,
              0.45, cv::Scalar::all(0), 1, cv::LINE_AA);
  for (int t = 0; t < tiles; ++t) {
    const CameraImage& image = set.images[t];
    if (image.camera < 0 || image.camera >= static_cast<int>(cameras.size())) {
      throw InputError("overlay: image of camera index " + std::to_string(image.camera) + " but " +
                       std::to_string(cameras.size()) + " cameras");
    }
    const Camera& camera = cameras[image.camera];
    cv::Mat tile = image.rgb.clone();
    const cv::Mat& mask =
        image.camera < static_cast<int>(foregrounds.size()) ? foregrounds[image.camera] : cv::Mat();
    if (!mask.empty() && mask.size() == tile.size()) {
      cv::Mat shaded;
      tile.convertTo(shaded, -1, kBackgroundShade);
      shaded.copyTo(tile, mask == 0);
    }
    if (result.has_pose) tile = drawModelOverlay(tile, camera, model, result.pose);
    pasteSheetTile(
        tile, camera.name,
        cv::Rect((t % columns) * tile_w, kHeaderPixels + (t / columns) * tile_h, tile_w, tile_h),
        &sheet);
  }
  return sheet;
}

void pasteSheetTile(const cv::Mat& tile, const std::string& label, const cv::Rect& where,
                    cv::Mat* sheet) {
  cv::Mat place = (*sheet)(where);
  if (tile.size() == where.size()) {
    tile.copyTo(place);
  } else {
    cv::resize(tile, place, where.size(), 0, 0, cv::INTER_AREA);
  }
  cv::putText(place, label, cv::Point(5, 15), cv::FONT_HERSHEY_SIMPLEX, 0.45,
              cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
}

bool OverlaySchedule::wants(const FrameResult& result) {
  const bool lost = result.status == TrackStatus::kLost;
  const bool first_lost = lost && !was_lost_;
  was_lost_ = lost;
  const bool periodic = every_ > 0 && count_ % every_ == 0;
  ++count_;
  return periodic || result.restarted || result.status == TrackStatus::kStarted || first_lost;
}

void prepareOverlayDir(const std::string& dir, const std::string& option) {
  namespace fs = std::filesystem;
  std::error_code error;
  const fs::file_status status = fs::symlink_status(dir, error);
  if (fs::exists(status)) {
    if (!fs::is_directory(fs::status(dir, error))) {
      throw InputError(option + " " + dir + ": is not a folder");
    }
    if (!fs::is_empty(dir, error) || error) {
      throw InputError(option + " " + dir +
                       ": already holds files; give a new or empty folder (the pictures never "
                       "replace a file)");
    }
    return;
  }
  fs::create_directories(dir, error);
  if (error)
    throw InputError(option + " " + dir + ": cannot create the folder: " + error.message());
}

std::string overlayPath(const std::string& dir, long frame_number) {
  char name[32];
  std::snprintf(name, sizeof(name), "frame_%06ld.png", frame_number);
  return (std::filesystem::path(dir) / name).string();
}

}  // namespace sag_hand_tracker
