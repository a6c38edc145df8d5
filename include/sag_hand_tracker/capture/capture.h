// Frame sources for live capture (no ROS): V4L2 devices, video files and image folders, and a
// multi-camera capture that grabs every camera first and then retrieves each, so the frames of one
// set are as close in time as the hardware allows. Used by the camera driver nodelet.
//
// Source strings (one per camera):
//   "0", "1", ...            V4L2 device by index
//   "/dev/video0"            V4L2 device by path (anything under /dev/)
//   "dir:/path/to/images"    an image folder, read in sorted (byte-wise) file name order
//   anything else            a video file (or any URL OpenCV's VideoCapture opens)
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

namespace sag_hand_tracker {

enum class SourceKind { kDevice, kVideoFile, kImageFolder };

struct SourceSpec {
  SourceKind kind = SourceKind::kVideoFile;
  std::string text;       // as given (for messages)
  int device_index = -1;  // a device given by number, else -1
  std::string path;       // device path, video file or folder; empty for a device index
};

// Parses one source string (surrounding white space ignored). Throws InputError for an empty
// string or "dir:" without a path.
SourceSpec parseSourceSpec(const std::string& text);

// "V4L2 device 0", "V4L2 device /dev/video1", "video file 'a.avi'", "image folder '/x'".
std::string describeSource(const SourceSpec& spec);

// Whether a file name has an image extension OpenCV reads (png, jpg, jpeg, bmp, ppm, pgm, pnm,
// tif, tiff, webp; case-insensitive).
bool isImageFileName(const std::string& name);

// The image files directly in `folder` (no sub-folders, no other files), as full paths sorted by
// file name. Throws InputError naming the folder if it does not exist or is not a folder.
std::vector<std::string> listImageFiles(const std::string& folder);

// `in` at width x height: resized (area interpolation when shrinking, linear when enlarging) when
// its size differs, else shared as is. A width or height of 0 keeps the source size.
cv::Mat fitFrame(const cv::Mat& in, int width, int height);

// The pinhole part of a camera_info (row-major K 3x3 and P 3x4, image size), ROS-free so that
// the driver's rescale is testable without ROS.
struct ImageIntrinsics {
  int width = 0;
  int height = 0;
  std::array<double, 9> K{};
  std::array<double, 12> P{};
};

// The intrinsics of the same camera after its images are resized (cv::resize) to width x height:
// K' = S K and P' = S P with S = [sx 0 (sx-1)/2; 0 sy (sy-1)/2; 0 0 1], sx = width / in.width,
// sy = height / in.height (the half-pixel terms because resize maps pixel centres, x' + 1/2 =
// sx (x + 1/2)). Distortion coefficients do not change (they act on normalised coordinates).
// Throws std::invalid_argument for a size that is not positive.
ImageIntrinsics scaleIntrinsics(const ImageIntrinsics& in, int width, int height);

// Any 8-bit 1/3/4-channel image (or a 16-bit one, scaled down) as 8-bit BGR; shares `in` when it
// already is. An empty image stays empty.
cv::Mat toBgr8(const cv::Mat& in);

struct SourceOptions {
  int width = 0;  // requested from devices (0 = the device's default)
  int height = 0;
  double fps = 0.0;    // requested from devices (0 = the device's default)
  std::string fourcc;  // pixel format requested from devices, e.g. "MJPG" ("" = default)
  bool loop = false;   // video files and folders: start again at the end
};

enum class GrabResult {
  kOk,        // a frame is ready for retrieve()
  kFailed,    // no frame this time (a device that did not deliver)
  kFinished,  // the end of a video file or folder without loop: no frame will come any more
};

// One camera. grab() latches a frame (fast), retrieve() decodes it.
class FrameSource {
 public:
  explicit FrameSource(SourceSpec spec) : spec_(std::move(spec)) {}
  virtual ~FrameSource() = default;
  FrameSource(const FrameSource&) = delete;
  FrameSource& operator=(const FrameSource&) = delete;

  virtual GrabResult grab() = 0;
  // The frame latched by the last successful grab(), as 8-bit BGR. False (and problem() says why)
  // if it cannot be decoded or read.
  virtual bool retrieve(cv::Mat* bgr) = 0;
  const std::string& problem() const { return problem_; }
  const SourceSpec& spec() const { return spec_; }

 protected:
  SourceSpec spec_;
  std::string problem_;
};

// Opens a source. Throws InputError naming it when it cannot be opened: a device or video file
// that does not exist or OpenCV cannot open, a folder that does not exist or holds no images.
std::unique_ptr<FrameSource> openFrameSource(const SourceSpec& spec, const SourceOptions& options);

enum class CameraState { kRunning, kNotOpened, kStopped, kFinished };

// When a stopped camera is tried again: the first attempt `first_delay` seconds after it
// stopped, then each failed attempt multiplies the wait by `factor`, up to `max_delay`.
struct ReopenBackoff {
  double first_delay = 0.5;
  double max_delay = 8.0;
  double factor = 2.0;
};

// The reopen attempts of one camera (times in seconds on any monotonic clock).
class ReopenSchedule {
 public:
  explicit ReopenSchedule(ReopenBackoff backoff = {});
  // The camera stopped at `now`: the first attempt is due first_delay later.
  void start(double now);
  bool started() const { return started_; }
  bool due(double now) const { return started_ && now >= next_attempt_; }
  // An attempt at `now` failed: the next one waits longer (up to max_delay).
  void failed(double now);
  // The camera runs again: the next stop starts from first_delay again.
  void reset();
  int attempts() const { return attempts_; }
  double delay() const { return delay_; }  // the current wait between attempts

 private:
  ReopenBackoff backoff_;
  bool started_ = false;
  double next_attempt_ = 0.0;
  double delay_ = 0.0;
  int attempts_ = 0;
};

// Opens a source again (openFrameSource with the driver's options); throws InputError when it
// cannot.
using SourceOpener = std::function<std::unique_ptr<FrameSource>(const SourceSpec&)>;

// Something the driver should report about a camera; each kind is reported once per camera except
// `read_failed`, which comes every time (the driver throttles it).
struct CaptureEvent {
  enum class Kind {
    kResized,       // the first frame whose size differs from width x height (it is resized)
    kReadFailed,    // no frame from this camera this time (grab or retrieve failed)
    kStopped,       // max_failures consecutive failures: the camera is no longer grabbed
    kFinished,      // end of a video file or folder without loop
    kReopenFailed,  // an attempt to reopen a stopped camera failed (comes every attempt)
    kReopened,      // a stopped camera was reopened and is grabbed again
  };
  int camera = -1;
  Kind kind = Kind::kReadFailed;
  std::string message;  // one line naming the camera and its source
};

// N cameras captured together. A camera that is not running is skipped; the others carry on.
class MultiCapture {
 public:
  // names.size() == sources.size(); a null source is a camera that could not be opened.
  // width/height: the output size (0 = each source's own); max_failures >= 1.
  MultiCapture(std::vector<std::string> names, std::vector<std::unique_ptr<FrameSource>> sources,
               int width, int height, int max_failures);

  // Stopped cameras (and ones that could not be opened) are reopened with `opener`, on the
  // schedule of `backoff`, from specs[i] (one per camera). Without this call they stay stopped.
  void enableReopen(std::vector<SourceSpec> specs, SourceOpener opener, ReopenBackoff backoff = {});
  // Tries to reopen the stopped cameras whose attempt is due at `now` (seconds, monotonic).
  void reopenDue(double now);

  // grab() on every running camera.
  void grabAll();
  // retrieve() on every camera whose grab succeeded: one entry per camera, RGB (CV_8UC3) at the
  // output size, or empty when the camera has no frame this time.
  std::vector<cv::Mat> retrieveAll();
  // The events since the last call.
  std::vector<CaptureEvent> takeEvents();

  int size() const { return static_cast<int>(cameras_.size()); }
  int runningCount() const;
  CameraState state(int camera) const { return cameras_.at(camera).state; }
  const std::string& name(int camera) const { return cameras_.at(camera).name; }

 private:
  struct Camera {
    std::string name;
    std::unique_ptr<FrameSource> source;
    CameraState state = CameraState::kRunning;
    bool grabbed = false;
    int failures = 0;  // consecutive
    bool resize_reported = false;
    std::optional<SourceSpec> spec;  // for reopening (enableReopen)
    ReopenSchedule reopen;
  };
  void fail(int camera, const std::string& why);
  std::string who(int camera) const;

  std::vector<Camera> cameras_;
  int width_ = 0;
  int height_ = 0;
  int max_failures_ = 1;
  std::vector<CaptureEvent> events_;
  SourceOpener opener_;
};

}  // namespace sag_hand_tracker
