// Named hands of the synthetic studio (issue 9): proportions (HandShape) and skin tone
// (SkinAlbedo), read from config/hand_shapes.yaml, so that the benchmark measures the tracker on
// hands other than its own model. Format (the file documents every key):
//
//   shapes:
//     - name: long_distal                 # [A-Za-z0-9_] only; `default` is the model's own hand
//       description: short proximal, long distal phalanges, lighter skin
//       scale: 1.0                        # overall size (optional, default 1)
//       finger_length: [1, 1, 1, 1, 1]    # thumb..pinky, or one number for all (default 1)
//       phalanx_length: [0.8, 1.0, 1.5]   # proximal, middle, distal for every finger, or a map
//                                         # {thumb: [..], index: [..], ...} (default 1)
//       palm_width: 1.0                   # across the knuckles (default 1)
//       palm_length: 1.0                  # wrist to knuckles (default 1)
//       thickness: 1.0                    # all radii (default 1)
//       knuckle_shift_mm: {ring: [-3, 0, -4]}      # per finger, the first joint moved on the
//                                         # palm (x to the fingers, y to the thumb, z out of the
//                                         # back), within +-15 mm (HandShape::knuckle_shift)
//       base_rotation_deg: {thumb: [10, 0, -8]}    # per finger, roll/pitch/yaw of the first bone
//                                         # at rest, within +-30 deg
//       flexion_tilt_deg: [0, 6, 2, -4, -8]        # thumb..pinky, the flexion axes turned about
//                                         # the bone, within +-20 deg
//       skin:                             # linear RGB albedos in [0, 1] (default: SkinAlbedo())
//         dorsal: [0.73, 0.41, 0.27]
//         palmar: [0.78, 0.44, 0.33]
//         nail: [0.82, 0.56, 0.50]
//
// Everything is explicit numbers: the same file gives the same hands.
#pragma once

#include <string>
#include <vector>

#include "sag_hand_tracker/studio/hand_surface.h"

namespace sag_hand_tracker {
namespace studio {

// Bounds of the skeleton's layout keys (hand_surface.h, HandShape): a real hand's joints sit
// within these of the model's; a value beyond them is a typo or a unit mix-up.
constexpr double kMaxKnuckleShiftMm = 15.0;
constexpr double kMaxBaseRotationDeg = 30.0;
constexpr double kMaxFlexionTiltDeg = 20.0;

struct StudioHand {
  std::string name = "default";
  std::string description;
  HandShape shape;
  SkinAlbedo skin;
};

// Parses a hand-shapes document. `source` names it in errors. Throws InputError naming the
// source, the line and the problem (unknown keys, factors that are not positive, colours outside
// [0, 1], duplicate or malformed names, an empty list).
std::vector<StudioHand> parseHandShapes(const std::string& yaml_text, const std::string& source);
std::vector<StudioHand> loadHandShapes(const std::string& path);

// `<config_dir>/hand_shapes.yaml`.
std::string handShapesPath(const std::string& config_dir);

// A hand by name from `<config_dir>/hand_shapes.yaml` ("default" is always known, even without
// the file), or a file in the same format holding exactly one shape. Throws InputError naming the
// known shapes when the name is unknown.
StudioHand resolveHandShape(const std::string& name_or_file, const std::string& config_dir);
// The file resolveHandShape reads for `name_or_file`: that file, or the config's hand shapes file
// for a name (an input that no output may replace).
std::string handShapeFile(const std::string& name_or_file, const std::string& config_dir);

// The names in `<config_dir>/hand_shapes.yaml`, in file order.
std::vector<std::string> handShapeNames(const std::string& config_dir);

// Hands drawn at random, for a test on hands nobody tuned the tracker on (the config's seven are
// the ones every change was measured on). `drawn<N>` (N in 0..1000000, no leading zeros) names the
// hand drawn with seed N: the same name gives the same hand on every machine. Within the
// config's envelope: size 0.9-1.1, each finger 0.95-1.05, phalanx proportions from the model's
// (t = 0) to long_distal's (t = 1, proximal -20 %, distal +50 %; thumb -15 % / +35 %) with t in
// [-0.3, 1] and each bone jittered by up to 5 %, palm 0.9-1.1 wide and long, thickness 0.8-1.2,
// the skin a mix of two of `skin_tones` (resolveHandShape: configSkinTones; empty: the default
// skin).
// resolveHandShape knows these names, so render_bag --shape, benchmark --shapes and
// calibrate_hand take them; a config shape may not be named so (parseHandShapes).
constexpr int kMaxDrawnHandSeed = 1000000;
// The seed of a `drawn<N>` name, or -1 when `name` is not one.
int drawnHandSeed(const std::string& name);
StudioHand drawHandShape(int seed, const std::vector<SkinAlbedo>& skin_tones);
// The distinct skin tones of `<config_dir>/hand_shapes.yaml` in file order (none without the
// file): a hand added with a tone already there changes none of the drawn hands.
std::vector<SkinAlbedo> configSkinTones(const std::string& config_dir);

}  // namespace studio
}  // namespace sag_hand_tracker
