#include "sag_hand_tracker/capture/capture.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <stdexcept>
#include <system_error>

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace fs = std::filesystem;

namespace {

std::string trim(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r\n");
  if (first == std::string::npos) return "";
  const auto last = text.find_last_not_of(" \t\r\n");
  return text.substr(first, last - first + 1);
}

std::string lower(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

bool allDigits(const std::string& text) {
  return !text.empty() && text.size() <= 6 &&
         std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
}

std::string sizeText(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

// --- image folder -------------------------------------------------------------------------------

class FolderSource : public FrameSource {
 public:
  FolderSource(SourceSpec spec, std::vector<std::string> files, bool loop)
      : FrameSource(std::move(spec)), files_(std::move(files)), loop_(loop) {}

  GrabResult grab() override {
    if (next_ >= files_.size()) {
      if (!loop_) {
        problem_ = "all " + std::to_string(files_.size()) + " images read (loop is off)";
        return GrabResult::kFinished;
      }
      next_ = 0;
    }
    current_ = next_++;
    return GrabResult::kOk;
  }

  bool retrieve(cv::Mat* bgr) override {
    if (current_ >= files_.size()) {
      problem_ = "retrieve() without a successful grab()";
      return false;
    }
    *bgr = cv::imread(files_[current_], cv::IMREAD_COLOR);
    if (bgr->empty()) {
      problem_ = "cannot read the image '" + files_[current_] + "'";
      return false;
    }
    return true;
  }

 private:
  std::vector<std::string> files_;
  bool loop_ = false;
  std::size_t next_ = 0;
  std::size_t current_ = static_cast<std::size_t>(-1);
};

// --- cv::VideoCapture: devices and video files
// ----------------------------------------------------

class CaptureSource : public FrameSource {
 public:
  CaptureSource(SourceSpec spec, const SourceOptions& options)
      : FrameSource(std::move(spec)), options_(options) {
    open();
  }

  bool isOpened() const { return capture_.isOpened(); }

  GrabResult grab() override {
    if (capture_.grab()) {
      ++frames_since_open_;
      return GrabResult::kOk;
    }
    if (spec_.kind == SourceKind::kDevice) {
      problem_ = "the device delivered no frame";
      return GrabResult::kFailed;
    }
    // A video file at its end.
    if (options_.loop && frames_since_open_ > 0) {
      open();
      if (capture_.isOpened() && capture_.grab()) {
        ++frames_since_open_;
        return GrabResult::kOk;
      }
      problem_ = "cannot read the video again from its start";
      return GrabResult::kFinished;
    }
    problem_ =
        "end of the video after " + std::to_string(frames_since_open_) + " frames (loop is off)";
    return GrabResult::kFinished;
  }

  bool retrieve(cv::Mat* bgr) override {
    cv::Mat frame;
    if (!capture_.retrieve(frame) || frame.empty()) {
      problem_ = "cannot decode the grabbed frame";
      return false;
    }
    *bgr = toBgr8(frame);
    return true;
  }

 private:
  void open() {
    frames_since_open_ = 0;
    if (spec_.kind != SourceKind::kDevice) {
      capture_.open(spec_.path, cv::CAP_ANY);
      return;
    }
    if (spec_.device_index >= 0) {
      capture_.open(spec_.device_index, cv::CAP_V4L2);
    } else {
      capture_.open(spec_.path, cv::CAP_V4L2);
    }
    if (!capture_.isOpened()) return;
    if (options_.fourcc.size() == 4) {
      const std::string& f = options_.fourcc;
      capture_.set(cv::CAP_PROP_FOURCC, cv::VideoWriter::fourcc(f[0], f[1], f[2], f[3]));
    }
    if (options_.width > 0) capture_.set(cv::CAP_PROP_FRAME_WIDTH, options_.width);
    if (options_.height > 0) capture_.set(cv::CAP_PROP_FRAME_HEIGHT, options_.height);
    if (options_.fps > 0.0) capture_.set(cv::CAP_PROP_FPS, options_.fps);
    // The newest frame, not one queued while the driver was busy.
    capture_.set(cv::CAP_PROP_BUFFERSIZE, 1);
  }

  SourceOptions options_;
  cv::VideoCapture capture_;
  long frames_since_open_ = 0;
};

}  // namespace

// --- parsing and helpers ------------------------------------------------------------------------

SourceSpec parseSourceSpec(const std::string& text) {
  SourceSpec spec;
  spec.text = trim(text);
  if (spec.text.empty()) throw InputError("empty camera source");
  if (spec.text.rfind("dir:", 0) == 0) {
    spec.kind = SourceKind::kImageFolder;
    spec.path = trim(spec.text.substr(4));
    if (spec.path.empty()) {
      throw InputError("camera source '" + spec.text + "': no folder after 'dir:'");
    }
  } else if (allDigits(spec.text)) {
    spec.kind = SourceKind::kDevice;
    spec.device_index = std::stoi(spec.text);
  } else if (spec.text.rfind("/dev/", 0) == 0) {
    spec.kind = SourceKind::kDevice;
    spec.path = spec.text;
  } else {
    spec.kind = SourceKind::kVideoFile;
    spec.path = spec.text;
  }
  return spec;
}

std::string describeSource(const SourceSpec& spec) {
  switch (spec.kind) {
    case SourceKind::kDevice:
      return "V4L2 device " +
             (spec.device_index >= 0 ? std::to_string(spec.device_index) : spec.path);
    case SourceKind::kImageFolder:
      return "image folder '" + spec.path + "'";
    case SourceKind::kVideoFile:
      break;
  }
  return "video file '" + spec.path + "'";
}

bool isImageFileName(const std::string& name) {
  static const char* const kExtensions[] = {".png", ".jpg", ".jpeg", ".bmp",  ".ppm",
                                            ".pgm", ".pnm", ".tif",  ".tiff", ".webp"};
  const std::string extension = lower(fs::path(name).extension().string());
  return std::any_of(std::begin(kExtensions), std::end(kExtensions),
                     [&](const char* known) { return extension == known; });
}

std::vector<std::string> listImageFiles(const std::string& folder) {
  std::error_code error;
  if (!fs::exists(folder, error)) {
    throw InputError("image folder '" + folder + "' does not exist");
  }
  if (!fs::is_directory(folder, error)) {
    throw InputError("image folder '" + folder + "' is not a folder");
  }
  std::vector<std::string> files;
  fs::directory_iterator it(folder, error);
  if (error) {
    throw InputError("image folder '" + folder + "' cannot be listed: " + error.message());
  }
  for (const fs::directory_entry& entry : it) {
    std::error_code entry_error;
    if (!entry.is_regular_file(entry_error)) continue;
    if (!isImageFileName(entry.path().filename().string())) continue;
    files.push_back(entry.path().string());
  }
  std::sort(files.begin(), files.end());
  return files;
}

cv::Mat fitFrame(const cv::Mat& in, int width, int height) {
  if (in.empty()) return in;
  const int w = width > 0 ? width : in.cols;
  const int h = height > 0 ? height : in.rows;
  if (in.cols == w && in.rows == h) return in;
  const bool shrinking = static_cast<long>(w) * h < static_cast<long>(in.cols) * in.rows;
  cv::Mat out;
  cv::resize(in, out, cv::Size(w, h), 0.0, 0.0, shrinking ? cv::INTER_AREA : cv::INTER_LINEAR);
  return out;
}

ImageIntrinsics scaleIntrinsics(const ImageIntrinsics& in, int width, int height) {
  if (in.width <= 0 || in.height <= 0 || width <= 0 || height <= 0) {
    throw std::invalid_argument("scaleIntrinsics: sizes must be positive, not " +
                                sizeText(in.width, in.height) + " -> " + sizeText(width, height));
  }
  const double sx = static_cast<double>(width) / in.width;
  const double sy = static_cast<double>(height) / in.height;
  ImageIntrinsics out = in;
  out.width = width;
  out.height = height;
  // Row r of S M is s_r * row r of M + shift_r * row 2 of M (row 2 of S is [0 0 1]).
  const auto scaleRows = [&](const double* m, double* result, int columns) {
    for (int c = 0; c < columns; ++c) {
      result[c] = sx * m[c] + 0.5 * (sx - 1.0) * m[2 * columns + c];
      result[columns + c] = sy * m[columns + c] + 0.5 * (sy - 1.0) * m[2 * columns + c];
      result[2 * columns + c] = m[2 * columns + c];
    }
  };
  scaleRows(in.K.data(), out.K.data(), 3);
  scaleRows(in.P.data(), out.P.data(), 4);
  return out;
}

cv::Mat toBgr8(const cv::Mat& in) {
  if (in.empty()) return in;
  cv::Mat eight = in;
  if (in.depth() == CV_16U) {
    in.convertTo(eight, CV_8U, 1.0 / 256.0);
  } else if (in.depth() != CV_8U) {
    in.convertTo(eight, CV_8U);
  }
  cv::Mat bgr;
  switch (eight.channels()) {
    case 1:
      cv::cvtColor(eight, bgr, cv::COLOR_GRAY2BGR);
      return bgr;
    case 4:
      cv::cvtColor(eight, bgr, cv::COLOR_BGRA2BGR);
      return bgr;
    default:
      return eight;
  }
}

std::unique_ptr<FrameSource> openFrameSource(const SourceSpec& spec, const SourceOptions& options) {
  const std::string what = describeSource(spec);
  if (spec.kind == SourceKind::kImageFolder) {
    std::vector<std::string> files = listImageFiles(spec.path);
    if (files.empty()) {
      throw InputError(what + " holds no image files (png, jpg, bmp, ppm, pgm, tif, webp)");
    }
    return std::make_unique<FolderSource>(spec, std::move(files), options.loop);
  }
  std::error_code error;
  // A plain path must exist (URLs, GStreamer pipelines and image sequences like img_%03d.png are
  // left to OpenCV).
  const bool plain_path = spec.path.find("://") == std::string::npos &&
                          spec.path.find_first_of("!%") == std::string::npos;
  if (!spec.path.empty() && plain_path && !fs::exists(spec.path, error)) {
    throw InputError(what + " does not exist");
  }
  auto source = std::make_unique<CaptureSource>(spec, options);
  if (!source->isOpened()) {
    if (spec.kind == SourceKind::kDevice) {
      throw InputError(what + " cannot be opened (is it connected, not used by another " +
                       "program, and is the user in the group 'video'?)");
    }
    throw InputError(what + " cannot be opened (not a video OpenCV can read)");
  }
  return source;
}

// --- reopening
// ------------------------------------------------------------------------------------

ReopenSchedule::ReopenSchedule(ReopenBackoff backoff) : backoff_(backoff) {
  backoff_.first_delay = std::max(0.0, backoff_.first_delay);
  backoff_.max_delay = std::max(backoff_.first_delay, backoff_.max_delay);
  backoff_.factor = std::max(1.0, backoff_.factor);
}

void ReopenSchedule::start(double now) {
  started_ = true;
  attempts_ = 0;
  delay_ = backoff_.first_delay;
  next_attempt_ = now + delay_;
}

void ReopenSchedule::failed(double now) {
  ++attempts_;
  delay_ = std::min(backoff_.max_delay, delay_ * backoff_.factor);
  next_attempt_ = now + delay_;
}

void ReopenSchedule::reset() {
  started_ = false;
  attempts_ = 0;
}

// --- MultiCapture
// ---------------------------------------------------------------------------------

MultiCapture::MultiCapture(std::vector<std::string> names,
                           std::vector<std::unique_ptr<FrameSource>> sources, int width, int height,
                           int max_failures)
    : width_(std::max(0, width)),
      height_(std::max(0, height)),
      max_failures_(std::max(1, max_failures)) {
  if (names.size() != sources.size()) {
    throw std::invalid_argument("MultiCapture: one name per source");
  }
  cameras_.resize(names.size());
  for (std::size_t i = 0; i < names.size(); ++i) {
    cameras_[i].name = std::move(names[i]);
    cameras_[i].source = std::move(sources[i]);
    if (!cameras_[i].source) cameras_[i].state = CameraState::kNotOpened;
  }
}

int MultiCapture::runningCount() const {
  return static_cast<int>(std::count_if(cameras_.begin(), cameras_.end(), [](const Camera& c) {
    return c.state == CameraState::kRunning;
  }));
}

std::string MultiCapture::who(int camera) const {
  const Camera& c = cameras_[camera];
  if (c.source) return "camera " + c.name + " (" + describeSource(c.source->spec()) + ")";
  if (c.spec) return "camera " + c.name + " (" + describeSource(*c.spec) + ")";
  return "camera " + c.name;
}

void MultiCapture::enableReopen(std::vector<SourceSpec> specs, SourceOpener opener,
                                ReopenBackoff backoff) {
  if (specs.size() != cameras_.size() || !opener) {
    throw std::invalid_argument("MultiCapture::enableReopen: one spec per camera and an opener");
  }
  opener_ = std::move(opener);
  for (std::size_t i = 0; i < cameras_.size(); ++i) {
    cameras_[i].spec = std::move(specs[i]);
    cameras_[i].reopen = ReopenSchedule(backoff);
  }
}

void MultiCapture::reopenDue(double now) {
  if (!opener_) return;
  for (int i = 0; i < size(); ++i) {
    Camera& c = cameras_[i];
    // A finished file or folder ended as it should; only failures are retried.
    if (c.state != CameraState::kStopped && c.state != CameraState::kNotOpened) continue;
    if (!c.reopen.started()) {
      c.reopen.start(now);
      continue;
    }
    if (!c.reopen.due(now)) continue;
    c.source.reset();  // a device must be closed before it can be opened again
    std::string why;
    try {
      c.source = opener_(*c.spec);
    } catch (const std::exception& e) {
      why = e.what();
    }
    if (!c.source) {
      if (why.empty()) why = "it cannot be opened";
      const int attempt = c.reopen.attempts() + 1;
      c.reopen.failed(now);
      char next[32];
      std::snprintf(next, sizeof(next), "%.1f", c.reopen.delay());
      events_.push_back({i, CaptureEvent::Kind::kReopenFailed,
                         who(i) + ": reopen attempt " + std::to_string(attempt) + " failed (" +
                             why + "); next attempt in " + next + " s"});
      continue;
    }
    const int attempts = c.reopen.attempts() + 1;
    c.reopen.reset();
    c.state = CameraState::kRunning;
    c.failures = 0;
    events_.push_back({i, CaptureEvent::Kind::kReopened,
                       who(i) + " reopened after " + std::to_string(attempts) +
                           (attempts == 1 ? " attempt" : " attempts") + "; it is grabbed again"});
  }
}

void MultiCapture::fail(int camera, const std::string& why) {
  Camera& c = cameras_[camera];
  ++c.failures;
  events_.push_back({camera, CaptureEvent::Kind::kReadFailed, who(camera) + ": " + why});
  if (c.failures >= max_failures_) {
    c.state = CameraState::kStopped;
    events_.push_back({camera, CaptureEvent::Kind::kStopped,
                       who(camera) + " stopped: no frame in " + std::to_string(c.failures) +
                           " consecutive attempts (" + why + "); the other cameras carry on"});
  }
}

void MultiCapture::grabAll() {
  for (int i = 0; i < size(); ++i) {
    Camera& c = cameras_[i];
    c.grabbed = false;
    if (c.state != CameraState::kRunning) continue;
    switch (c.source->grab()) {
      case GrabResult::kOk:
        c.grabbed = true;
        break;
      case GrabResult::kFailed:
        fail(i, c.source->problem());
        break;
      case GrabResult::kFinished:
        c.state = CameraState::kFinished;
        events_.push_back({i, CaptureEvent::Kind::kFinished,
                           who(i) + " has no more frames: " + c.source->problem() +
                               "; the other cameras carry on"});
        break;
    }
  }
}

std::vector<cv::Mat> MultiCapture::retrieveAll() {
  std::vector<cv::Mat> frames(cameras_.size());
  for (int i = 0; i < size(); ++i) {
    Camera& c = cameras_[i];
    if (!c.grabbed) continue;
    c.grabbed = false;
    cv::Mat bgr;
    if (!c.source->retrieve(&bgr) || bgr.empty()) {
      fail(i, c.source->problem());
      continue;
    }
    c.failures = 0;
    const cv::Mat fitted = fitFrame(bgr, width_, height_);
    if (fitted.size() != bgr.size() && !c.resize_reported) {
      c.resize_reported = true;
      events_.push_back({i, CaptureEvent::Kind::kResized,
                         who(i) + " delivers " + sizeText(bgr.cols, bgr.rows) +
                             " frames; resizing them to " + sizeText(fitted.cols, fitted.rows)});
    }
    cv::cvtColor(fitted, frames[i], cv::COLOR_BGR2RGB);
  }
  return frames;
}

std::vector<CaptureEvent> MultiCapture::takeEvents() {
  std::vector<CaptureEvent> events;
  events.swap(events_);
  return events;
}

}  // namespace sag_hand_tracker
