// Streamed reading of a multi-camera bag without a ROS master (rosbag_storage).
//
// A bag is a complete input (doc/design.md section 6) when it holds, for cameras i = 0..N-1:
//   /cam<i>/image_raw    sensor_msgs/Image, rgb8 or bgr8
//   /cam<i>/camera_info  sensor_msgs/CameraInfo (the first message is the calibration)
//   /tf_static           tf2_msgs/TFMessage: root -> cam<i>_optical_frame (or the camera_info's
//                        frame_id), directly or through intermediate frames
// Images are grouped into frame sets by identical header stamps. Reading is streamed: the bag's
// index is read when it opens, then one image at a time; at most a few sets are held while a set
// waits for its late images.
//
// Decode time is measured separately from processing: BagReader::next() does all the reading,
// deserialising and colour conversion, and accumulates its own time in statistics().
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sag_hand_tracker/camera/camera.h"
#include "sag_hand_tracker/tracking/frame_set.h"

namespace rosbag {
class Bag;
}

namespace sag_hand_tracker {

struct BagReaderOptions {
  // Camera ids (the i of cam<i>) to read; empty = every camera in the bag. Sets are then made of
  // these cameras only, in this order of ids (sorted).
  std::vector<int> cameras;
  // The frame the extrinsics are expressed in; empty = the root of the tf tree that holds the
  // cameras (which must then be one tree).
  std::string root_frame;
  // At most this many incomplete sets wait for late images; the oldest is then yielded as it is.
  int max_pending_sets = 8;
  // Images of different cameras whose stamps differ by at most this (seconds) are one set, stamped
  // with the first one's stamp: cameras that are not stamped together (free-running drivers, one
  // node per camera). 0: identical stamps only. Keep it below half the frame period (5 ms: rigs up
  // to 100 fps); one camera's consecutive images never join one set.
  double stamp_tolerance = 0.005;
};

// A camera's stamps that leap forward by more than this (a clock set forward, a paused recording)
// are reported (BagReaderStatistics::forward_jumps); calibrate_hand counts no such gap as time.
constexpr double kStampJumpSeconds = 10.0;

struct BagReaderStatistics {
  std::uint64_t image_messages = 0;  // image messages of the selected cameras in the bag
  // The most image messages of one selected camera: the bag gives at least this many sets.
  std::uint64_t most_camera_images = 0;
  std::uint64_t images_read = 0;      // image messages read so far
  std::uint64_t sets = 0;             // sets yielded so far
  std::uint64_t incomplete_sets = 0;  // yielded sets without every selected camera
  std::uint64_t dropped_images = 0;   // duplicates, or stamps older than a set already yielded
  double decode_seconds = 0.0;        // time spent in next(): reading, deserialising, converting
  double stamp_tolerance = 0.0;       // the reader's BagReaderOptions::stamp_tolerance
  // Images whose stamp is older than the previous image of the same camera (reported, and
  // dropped when their set is gone); the first one as "topic frame N at stamp after stamp" (N:
  // the image's number on its topic, from 1).
  std::uint64_t backward_stamps = 0;
  std::string first_backward_stamp;
  // Images of a camera at a stamp it already delivered (dropped: one image per camera and set);
  // the first one as "topic frame N at stamp".
  std::uint64_t duplicate_stamps = 0;
  std::string first_duplicate_stamp;
  // Images whose stamp is more than 10 s after the previous image of the same camera (a clock
  // set forward, a paused recording: read as the next frame); the first one as "topic frame N at
  // stamp after stamp".
  std::uint64_t forward_jumps = 0;
  std::string first_forward_jump;
  // Images that started a set of their own while another camera's set without them lay within
  // 20 ms (beyond stamp_tolerance): the cameras are not stamped together, so sets lack cameras.
  // The first one as "topic frame N at stamp vs camera at stamp".
  std::uint64_t near_stamp_mismatches = 0;
  std::string first_near_stamp_mismatch;
  // Images that joined a set of another stamp (within stamp_tolerance), and the largest difference
  // between an image's stamp and its set's (seconds).
  std::uint64_t tolerated_stamps = 0;
  double largest_stamp_difference = 0.0;
};

// The reader's stamp checks in words, the same for every tool that reads a bag (track_bag,
// calibrate_hand): one line per problem found, naming the first image (topic, frame number, stamp)
// and what the reading did with such images. Empty when the stamps were in order.
// `tolerance_option` names the option that sets the stamp tolerance, empty if the tool has none.
std::vector<std::string> stampWarnings(const BagReaderStatistics& stats,
                                       const std::string& tolerance_option = "");

// Why a bag of which `sets` sets were read gave nothing to work with, when the stamps explain it:
// cameras never stamped together, or more images dropped (stamps going backwards, or repeated)
// than sets kept. "" when the stamps do not explain it.
std::string stampFailure(const BagReaderStatistics& stats, long sets,
                         const std::string& tolerance_option = "");

// Whether the cameras were not stamped together in at least a tenth of the `sets` sets read
// (near_stamp_mismatches; a camera that skips a frame at a high frame rate counts too, hence the
// share). Their sets lack cameras, and a tool that must see the hand from every camera at once
// (calibrate_hand) refuses them.
bool camerasOutOfStep(const BagReaderStatistics& stats, long sets);

// Whether BagReader reads the images of a camera of this name: cam<i>, i < kMaxCameras, written
// as the reader looks it up (no leading zeros). A bag writer's other names go on topics the
// reader passes over.
bool isBagCameraName(const std::string& name);

class BagReader {
 public:
  // Opens the bag, finds the cameras, reads their calibration and extrinsics and checks the first
  // image of every camera. Throws InputError with a one-line message naming the bag and the
  // problem: missing or unreadable bag, empty bag (no frames), no /cam<i>/image_raw topic, an
  // unknown camera in options.cameras, a camera without camera_info, missing extrinsics, a wrong
  // message type, an unsupported (for example mono) encoding, an image whose size differs from
  // its camera_info, a camera_info whose size changes mid-bag, a selected camera with compressed
  // images only (/cam<i>/image_raw/compressed), or a truncated or unclosed bag.
  explicit BagReader(const std::string& path, const BagReaderOptions& options = {});
  // The same, reading through the caller's `reused_bag` instead of a rosbag::Bag of its own. It
  // must be closed (the reader made with it before is gone) and outlive the reader, which closes it
  // again when destroyed, also when this constructor throws; rosbag's close() resets all that
  // reading set, so the next reader can open the next file in it. For callers that read many small
  // bags (the bag fuzz target): making a rosbag::Bag (pluginlib's search for encryptor plugins, a
  // 1 MB lz4 buffer) costs more than reading such a bag. Every check is the same.
  BagReader(const std::string& path, rosbag::Bag& reused_bag, const BagReaderOptions& options = {});
  ~BagReader();
  BagReader(BagReader&&) noexcept;
  BagReader& operator=(BagReader&&) noexcept;
  BagReader(const BagReader&) = delete;
  BagReader& operator=(const BagReader&) = delete;

  const std::string& path() const;
  const std::string& rootFrame() const;
  // The selected cameras ("cam<i>"), with their calibration and world_to_camera (root frame ->
  // optical frame). CameraImage::camera indexes this list.
  const std::vector<Camera>& cameras() const;
  // The id i of each selected camera, parallel to cameras().
  const std::vector<int>& cameraIds() const;

  // The next frame set, in stamp order; false when the bag is exhausted. Throws InputError (naming
  // the topic and stamp) for an image with an unsupported encoding or a size that disagrees with
  // its camera_info.
  bool next(FrameSet* set);

  const BagReaderStatistics& statistics() const;
  // Fraction of the image messages read so far, in [0, 1], for progress reports.
  double progress() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sag_hand_tracker
