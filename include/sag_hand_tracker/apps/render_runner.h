// The body of render_bag as a library function, so that the benchmark renders its bags with
// exactly the code of the tool: a studio sequence into a bag in the interface that track_bag reads
// (/cam<i>/image_raw rgb8, /cam<i>/camera_info, /tf_static root -> cam<i>_optical_frame, identical
// stamps per set), with the ground truth in the bag (/ground_truth/joint_states,
// /ground_truth/fingertips) and in a CSV with track_bag's columns. No ROS master needed.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "sag_hand_tracker/apps/command_line.h"
#include "sag_hand_tracker/apps/progress.h"
#include "sag_hand_tracker/ros/bag_output.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

struct RenderBagOptions {
  std::string sequence;                  // --sequence name|file (required)
  std::string rig = "dexter5";           // --rig name|dir|file
  std::string out;                       // --out OUT.bag (required)
  std::string gt_csv;                    // --gt-csv FILE (default: OUT with .gt.csv)
  std::string config_dir;                // --config-dir DIR (default: the package's config/)
  std::string model = "sag";             // --model sag|FILE: the skeleton the hand is rendered on
  Handedness hand = Handedness::kRight;  // --hand left|right: the model mirrored if needed
  double fps = 25.0;                     // --fps
  int frames = 0;                        // --frames N (0: the motion's duration)
  int empty_frames = -1;                 // --empty-frames N (-1: 10; 0 in a room without them)
  std::uint64_t seed = 1;                // --seed S
  int motion_blur = 1;                   // --motion-blur N sub-frames (1: none)
  double exposure = 0.010;               // --exposure SECONDS (motion blur)
  double noise = 2.0;                    // --noise SIGMA (8-bit levels)
  double hand_scale = 1.0;               // --hand-scale S (on top of the shape's scale)
  std::string shape = "default";         // --shape NAME|FILE (config/hand_shapes.yaml)
  bool bare_forearm = false;             // --bare-forearm: no sleeve up to the elbow region
  double palm_width = 1.0;               // --palm-width F (on top of the shape's)
  std::array<double, kNumFingers> finger_length{{1, 1, 1, 1, 1}};  // --finger-length F[,F x4]
  double thickness = 1.0;             // --thickness F (on top of the shape's)
  std::string preview;                // --preview PNG: contact sheet of one frame
  int preview_frame = -1;             // --preview-frame N (default: the middle frame)
  double start_stamp = 1400000000.0;  // --start-stamp SECONDS of the first frame
  BagCompression compression = BagCompression::kNone;  // --compression none|lz4|bz2
  std::string room;         // --room office|kitchen|daylight ("" = the clean studio)
  bool hand_masks = false;  // --hand-masks: /cam<i>/hand_mask, the tracked hand's pixels
  int threads = 2;          // --threads N: views rendered at once (same images for any N)
  bool overwrite = false;   // --overwrite: replace files at --out, --gt-csv, --preview
  bool quiet = false;
  bool help = false;
};

// Parses the arguments after the program name (fills gt_csv from out when not given). Throws
// UsageError.
RenderBagOptions parseRenderBagArguments(const std::vector<std::string>& args);
std::string renderBagUsage();

struct RenderBagSummary {
  std::string sequence;       // the motion's name
  std::string shape;          // the hand shape's name
  bool bare_forearm = false;  // rendered with a bare forearm
  std::string bag;
  std::string gt_csv;
  std::string preview;   // empty: none
  int frames = 0;        // sets written
  int empty_frames = 0;  // of which without the hand
  int gt_rows = 0;       // ground-truth rows (= frames with the hand)
  int cameras = 0;
  double fps = 0.0;  // the sequence's frame rate
  std::uint64_t seed = 0;
  double render_seconds = 0.0;  // rendering the images only
  double total_seconds = 0.0;   // the frame loop, with the bag and the CSV
  double setup_seconds = 0.0;   // the studio renderer's set-up
};

// Renders the sequence. `progress` may be null (no progress). Throws InputError for bad input,
// and Interrupted when `stop` (may be null) becomes true between two frames; either way the
// outputs' temporary files are removed and what was at their paths is left as it was.
RenderBagSummary renderStudioBag(const RenderBagOptions& options, ProgressBar* progress,
                                 const std::atomic<bool>* stop = nullptr);

// renderStudioBag was stopped (render_bag: Ctrl-C or SIGTERM).
struct Interrupted : std::runtime_error {
  Interrupted() : std::runtime_error("interrupted; nothing was written") {}
};

// The tool's closing report (several lines).
std::string formatRenderBagSummary(const RenderBagSummary& summary);

}  // namespace sag_hand_tracker
