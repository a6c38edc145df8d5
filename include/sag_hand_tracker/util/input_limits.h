// The one validation policy for data entering the core: explicit size limits, checked before
// anything is allocated, and the checks every reader shares (finite numbers, names that are safe
// as ROS topic and frame names, image sizes). README "Input limits" lists the same numbers.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace sag_hand_tracker {

// Any YAML input (model, rig, camera calibration, motion, hand shapes). Ours are a few kB.
constexpr std::size_t kMaxYamlFileBytes = 1u << 20;  // 1 MiB
// Maps and lists nested in each other in any YAML input (ours are at most 5 deep). Checked while
// the text is parsed, before yaml-cpp recurses any deeper (10000 '[' gave a bare "bad file").
constexpr int kMaxYamlNestingDepth = 64;
// Gaussians of a hand model: the energy costs model x image Gaussians per camera and frame, and
// calibrate_hand's fit many energies per candidate (SAG 17, SoG 30; a model of 1000 made
// calibrate_hand run for hours). Twice the SoG model's leaves room for finer models.
constexpr int kMaxModelGaussians = 64;
// Standard deviations of a hand model's Gaussians (sigma): 0.1 mm. A smaller one is no finger
// surface, and its square underflows or is lost against the other axes (1e-300 made the covariance
// singular). Ours, fitted ones included, are at least 3.6 mm.
constexpr double kMinModelSigmaMetres = 1e-4;
// Bones of a hand model (ours 16).
constexpr int kMaxModelBones = 100;
// An image side and the pixels of one image (camera_info, calibration files, image messages).
constexpr int kMaxImageSide = 8192;
constexpr std::int64_t kMaxImagePixels = 4096LL * 4096LL;
// Gaussians of one image SoG (a 4096x4096 image in 4-pixel leaves is about a million; ours ~300).
constexpr int kMaxImageGaussians = 1 << 20;
// Focal lengths in pixels (fx, fy): anything larger is not a camera lens.
constexpr double kMaxFocalLengthPixels = 1e6;
// ... and anything below a pixel is not one either (4.6e-305 gave NaN undistortion: a fuzz find).
constexpr double kMinFocalLengthPixels = 1.0;
// Cameras of a rig or a bag.
constexpr int kMaxCameras = 64;
// Camera translations (rig files, a bag's /tf_static): a rig is a room, not a continent (and huge
// values overflow the inverse transform).
constexpr double kMaxRigExtentMetres = 1000.0;  // metres, each coordinate
// Two camera centres closer than this are one point (a rig with all cameras at the origin).
constexpr double kMinCameraSeparation = 1e-3;  // metres
// Keyframes of a motion, random ones included (a motion `interval` of 1e-9 would draw 1e10).
// Counted before any is drawn; the random-keyframe spacing check is quadratic in it.
constexpr int kMaxMotionKeyframes = 10000;
// Keyframe times, `from`/`to` and `duration` of a motion (an hour of synthetic video).
constexpr double kMaxMotionSeconds = 3600.0;

// True for a name that is safe as one ROS graph/topic name component and a tf frame: a letter,
// then letters, digits and underscores (so "../../etc", "a/b", "" and "cam 0" are not).
bool isSafeName(const std::string& name);

// Throws InputError "<who>: image size WxH ..." when a side is not positive or the image exceeds
// kMaxImageSide / kMaxImagePixels.
void checkImageSize(std::int64_t width, std::int64_t height, const std::string& who);

}  // namespace sag_hand_tracker
