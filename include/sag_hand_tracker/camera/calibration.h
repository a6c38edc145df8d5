// Camera calibration files: one camera_calibration_parsers YAML file per camera (intrinsics) and
// one rig file (extrinsics) that ties the cameras to a root frame. No ROS.
//
// Per-camera file (the format of camera_calibration_parsers / camera_info_manager):
//
//   image_width: 320
//   image_height: 240
//   camera_name: cam0
//   camera_matrix: {rows: 3, cols: 3, data: [fx, 0, cx, 0, fy, cy, 0, 0, 1]}
//   distortion_model: plumb_bob          # or rational_polynomial
//   distortion_coefficients: {rows: 1, cols: 5, data: [k1, k2, p1, p2, k3]}
//   rectification_matrix: {rows: 3, cols: 3, data: [1, 0, 0, 0, 1, 0, 0, 0, 1]}
//   projection_matrix: {rows: 3, cols: 4, data: [fx, 0, cx, 0, 0, fy, cy, 0, 0, 0, 1, 0]}
//
// Reading requires image_width, image_height and camera_matrix; a missing distortion means none.
// The rectification and projection matrices are checked for shape and otherwise ignored (the
// tracker works on raw images with K and the distortion). Writing always writes every key.
//
// Rig file (extrinsics), our own format:
//
//   root_frame: world                 # the fixed frame of the rig (REP-103, metres)
//   cameras:
//     - name: cam0                    # its optical frame is cam0_optical_frame
//       calibration: cam0.yaml        # camera_calibration_parsers file, relative to the rig file
//       translation: [x, y, z]        # origin of cam0_optical_frame in the root frame (metres)
//       rotation: [qx, qy, qz, qw]    # orientation of cam0_optical_frame in the root frame
//
// translation + rotation is the transform root_frame -> cam<i>_optical_frame exactly as tf
// publishes it (parent root_frame, child the optical frame): it maps points in the camera frame to
// the root frame. Camera::world_to_camera is its inverse. The quaternion must be of unit length
// (within 1e-3; it is then normalised). The rig's `name` wins over the file's camera_name.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "sag_hand_tracker/camera/camera.h"

namespace sag_hand_tracker {

struct CameraRig {
  std::string root_frame = "world";
  std::vector<Camera> cameras;  // in file order, world_to_camera set from the rig
};

// The optical frame of a camera: "<name>_optical_frame" (doc/design.md section 6).
std::string opticalFrame(const std::string& camera_name);

// Parses a camera_calibration_parsers YAML document. `source` names it in errors (usually the
// file path). Camera::world_to_camera is left as the identity. Throws InputError.
Camera parseCameraCalibration(const std::string& yaml_text, const std::string& source);
// Reads a camera_calibration_parsers YAML file. Throws InputError naming the file and the problem.
Camera loadCameraCalibration(const std::string& path);

// The camera_calibration_parsers YAML document of a camera (shortest round-trip numbers).
// Without distortion it writes plumb_bob with 5 zeros; R is the identity and P = [K | 0].
std::string cameraCalibrationToYaml(const Camera& camera);
// Writes cameraCalibrationToYaml to `path`. Throws InputError if the file cannot be written.
void saveCameraCalibration(const std::string& path, const Camera& camera);

// Reads a rig file and every calibration file it names. Throws InputError naming the file (the
// rig or a camera's calibration file), the line where there is one, and the problem.
// `calibration_files`, when given, receives the paths of the calibration files read.
CameraRig loadCameraRig(const std::string& path,
                        std::vector<std::string>* calibration_files = nullptr);
// Parses a rig document; `load_calibration` reads the calibration file a camera names (as
// written in the rig). loadCameraRig resolves it relative to the rig file. Camera names must be
// safe as topic and frame names, camera centres at least kMinCameraSeparation apart.
using CalibrationLoader = std::function<Camera(const std::string& file)>;
CameraRig parseCameraRig(const std::string& yaml_text, const std::string& source,
                         const CalibrationLoader& load_calibration);

// Writes a rig file at `path` and one calibration file per camera, "<name>.yaml", in the same
// directory. Throws InputError if a file cannot be written or two cameras share a name.
void saveCameraRig(const std::string& path, const CameraRig& rig);

}  // namespace sag_hand_tracker
