// Hand motions of the synthetic studio, as data: keyframe files (YAML) interpolated smoothly, with
// optional seeded random keyframes and jitter. Format (config/motions/README.md has the long form):
//
//   name: pinch                         # optional, defaults to the file name
//   description: thumb meets each finger
//   duration: 12.0                      # seconds; default: the last keyframe's time
//   interpolation: cubic                # cubic (Catmull-Rom, default) or linear
//   shapes:                             # optional named hand shapes: joint angles in degrees
//     fist: {index_mcp_flexion: 85, index_pip_flexion: 100}
//   keyframes:                          # at least one; times strictly increasing
//     - time: 0.0                       # seconds from the first frame of the sequence
//       position: [0.0, -0.03, 0.15]    # wrist, metres, root frame (z up, table at z = 0)
//       orientation: [0, 0, 0]          # roll, pitch, yaw in degrees, see motionOrientation()
//       shape: fist                     # optional: start from a named shape
//       joints: {index_dip_flexion: 20} # optional: degrees, override the shape
//   forearm: {bare: true, bend: 1.5}    # optional: a bare forearm (no sleeve up to the elbow
//                                       # region) and how far it bends towards the body
//   random:                             # optional, drawn from the seed
//     keyframes:                        # extra keyframes drawn uniformly every `interval` s
//       from: 2.0                       # in [from, to]; a list of such blocks is allowed too
//       to: 12.0
//       interval: 0.4
//       position: [0.10, 0.08, 0.06]    # half-ranges (m) around the explicit motion's position
//       orientation: [60, 40, 90]       # half-ranges (deg) around its roll, pitch, yaw
//       joints: 0.8                     # fraction of each joint's range used, centred
//     jitter:                           # smooth noise on every channel (sums of sinusoids)
//       position: 0.004                 # amplitude (m)
//       orientation: 3.0                # amplitude (deg)
//       joints: 4.0                     # amplitude (deg)
//       frequency: 1.0                  # mean frequency (Hz)
//
// Joint names are the hand model's parameter names (HandModel::parameterNames(), entries 6..25).
// A keyframe that lists no value for a joint keeps the previous keyframe's value (the first
// keyframe starts from the neutral pose: 0 clamped into the limits). Every keyframe value must lie
// within the model's limits; interpolation overshoot and jitter are clamped into them. Errors
// throw InputError naming the file, the line and the problem.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/pose.h"

namespace sag_hand_tracker {
namespace studio {

using JointVector = Eigen::Matrix<double, kNumJointDof, 1>;

struct MotionKeyframe {
  double time = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();     // metres
  Eigen::Vector3d orientation = Eigen::Vector3d::Zero();  // roll, pitch, yaw (degrees)
  JointVector joints = JointVector::Zero();               // radians, model order
  bool random = false;                                    // drawn from the seed
};

// Smooth noise: per channel (3 position, 3 orientation, 20 joints) a sum of sinusoids.
struct MotionJitter {
  struct Wave {
    double amplitude = 0.0;  // metres, degrees or radians (joints)
    double frequency = 0.0;  // Hz
    double phase = 0.0;      // radians
  };
  std::vector<std::vector<Wave>> channels;  // 26 channels, empty when there is no jitter
  double value(int channel, double time) const;
};

struct Motion {
  std::string name;
  std::string description;
  std::string source;  // file it came from
  double duration = 0.0;
  bool cubic = true;
  std::vector<MotionKeyframe> keyframes;  // sorted by time, random ones included
  MotionJitter jitter;
  // The motion's forearm, when it sets one (`forearm:` key): `bare: true` renders a bare forearm
  // (HandSurfaceParams::bare_forearm) whatever the caller asked; `bend` overrides forearm_bend.
  std::optional<bool> bare_forearm;
  std::optional<double> forearm_bend;
  JointVector joint_min = JointVector::Zero();  // the model's limits (radians)
  JointVector joint_max = JointVector::Zero();

  // The pose at `time` seconds (held before the first and after the last keyframe); joints are
  // clamped into the limits.
  Pose poseAt(double time) const;
};

// The palm orientation of a keyframe: R = Rz(90 deg) * Rz(yaw) * Ry(pitch) * Rx(roll), angles in
// degrees. At zero the palm faces down (its z, the back of the hand, is world +z) and the fingers
// point along world +y, away from the person; roll turns about the hand's long axis (positive
// lifts the thumb side of a right hand), pitch tilts the fingers (positive: down), yaw swings them
// (positive: towards the thumb of a right hand, i.e. to world -x).
Eigen::Matrix3d motionOrientation(const Eigen::Vector3d& roll_pitch_yaw_deg);

// Parses a motion document for `model`. `source` names it in errors; `seed` drives the random
// parts (the same seed gives the same motion).
Motion parseMotion(const std::string& yaml_text, const std::string& source, const HandModel& model,
                   std::uint64_t seed);
// Reads a motion file. Throws InputError naming the file and the problem.
Motion loadMotion(const std::string& path, const HandModel& model, std::uint64_t seed);

// The built-in sequences, named after Dexter 1's: adbadd, fingercount, fingerwave, flexex1,
// pinch, random, tigergrasp.
const std::vector<std::string>& builtinMotionNames();
// Issue 9's harder motions (natural, not palm-down over the table): raised, pronation,
// wristflex, fastturn, natural (everyday grips whose finger joints are not tied to each other).
const std::vector<std::string>& hardMotionNames();
// A built-in name (of either list) -> `<config_dir>/motions/<name>.yaml`; anything else is taken
// as a path.
std::string resolveMotionPath(const std::string& name_or_path, const std::string& config_dir);

}  // namespace studio
}  // namespace sag_hand_tracker
