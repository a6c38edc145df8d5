// The rendered hand of the synthetic studio: a surface of tapered capsules (sphere-swept cones)
// along the bones, a palm of swept polygons and cones, and a forearm in a black sleeve, posed by
// the hand model's skeleton. It deliberately shares nothing with the tracker's Gaussians but the
// skeleton, so that rendering and tracking do not commit the same modelling errors.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <vector>

#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/studio/primitives.h"

namespace sag_hand_tracker {
namespace studio {

// Bones of each finger (thumb..pinky), proximal to distal; the first one's parent is the palm.
// Found from HandModel::fingertip_gaussians (the distal bone of each finger), or, when those are
// unset, from the bone names. Throws InputError if the model has no such structure.
std::array<std::vector<int>, kNumFingers> fingerChains(const HandModel& model);

// Size and proportions of the rendered hand. They change the skeleton (bone offsets and lengths)
// so that the ground truth follows the rendered hand, see shapeHandModel. Named shapes with skin
// tones are in config/hand_shapes.yaml (hand_shapes.h).
struct HandShape {
  double scale = 1.0;  // overall size
  // Per finger (thumb..pinky): factor on the bone lengths of that finger.
  std::array<double, kNumFingers> finger_length{{1.0, 1.0, 1.0, 1.0, 1.0}};
  // Per finger and bone, proximal to distal (for the thumb: metacarpal, proximal, distal): a
  // further factor on that one bone's length, e.g. shorter proximal and longer distal phalanges.
  std::array<std::array<double, 3>, kNumFingers> phalanx_length{{{{1.0, 1.0, 1.0}},
                                                                 {{1.0, 1.0, 1.0}},
                                                                 {{1.0, 1.0, 1.0}},
                                                                 {{1.0, 1.0, 1.0}},
                                                                 {{1.0, 1.0, 1.0}}}};
  double palm_width = 1.0;   // factor on the knuckles' spread across the palm
  double palm_length = 1.0;  // factor on the knuckles' distance from the wrist, along the palm
  double thickness = 1.0;    // factor on all radii (fingers, palm, wrist, forearm)

  // The skeleton's own layout. A real hand's joints do not sit where the model's do, so these
  // change what the tracker's model cannot follow by any pose or length (zero: the model's).
  // Per finger (thumb..pinky):
  //   knuckle_shift   the first bone's origin moved on the palm, metres at scale 1, in the palm
  //                   frame (x toward the fingers, y toward the thumb, z out of the back); e.g.
  //                   a curved row of knuckles, the ring and little knuckles lower (palmar);
  //   base_rotation   the first bone's rest orientation turned by (roll, pitch, yaw) radians,
  //                   composed as the model's rest_rpy_deg: a finger splayed or tilted at rest,
  //                   a thumb that leaves the palm at another angle;
  //   flexion_tilt    the finger's flexion axes (the joints that turn about the bone's y axis)
  //                   turned about the bone by this many radians, so that the finger curls
  //                   sideways: real fingers converge toward the palm's base as they close.
  std::array<Eigen::Vector3d, kNumFingers> knuckle_shift{
      {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
       Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()}};
  std::array<Eigen::Vector3d, kNumFingers> base_rotation{
      {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
       Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()}};
  std::array<double, kNumFingers> flexion_tilt{{0.0, 0.0, 0.0, 0.0, 0.0}};

  // The factor on the length of bone `phalanx` (0..2) of finger `finger`.
  double boneFactor(int finger, int phalanx) const {
    return scale * finger_length[finger] * phalanx_length[finger][phalanx];
  }
};

// The model with the skeleton scaled by `shape`: each finger bone's length by
// shape.boneFactor(finger, phalanx), a child's offset along its parent by the parent's factor, the
// palm's children (the first bone of each finger) across the palm by scale * palm_width and along
// it by scale * palm_length; the Gaussians move and stretch with their bones (along the bone by
// its factor, across by scale * finger_length) so that the result stays a consistent model. Then
// the skeleton's layout: each finger's first bone moved by scale * knuckle_shift and turned by
// base_rotation, its flexion axes tilted by flexion_tilt.
// Throws InputError on non-positive or non-finite factors and non-finite layout values.
HandModel shapeHandModel(const HandModel& model, const HandShape& shape);

// Fingertips of the rendered hand (thumb..pinky): the distal bone's end, origin + length * x. The
// rendered distal capsule ends exactly there, its rounded cap included.
Fingertips boneFingertips(const HandModel& model,
                          const std::vector<Eigen::Isometry3d>& bone_frames);

// Labels of the label image (one byte per pixel).
enum SurfaceLabel : std::uint8_t {
  kLabelBackground = 0,
  kLabelSleeve = 1,
  kLabelForearm = 2,  // the bare skin of the wrist
  kLabelPalm = 3,
  kLabelFirstFingerBone = 4,  // + 3 * finger + phalanx (0 proximal .. 2 distal), up to 18
};
inline std::uint8_t fingerBoneLabel(int finger, int phalanx) {
  return static_cast<std::uint8_t>(kLabelFirstFingerBone + 3 * finger + phalanx);
}
bool isSkinLabel(std::uint8_t label);

// Colours are linear RGB albedos in [0, 1].
struct SkinAlbedo {
  Eigen::Vector3f dorsal{0.73f, 0.41f, 0.27f};     // back of the hand and fingers
  Eigen::Vector3f palmar{0.78f, 0.44f, 0.33f};     // palm side: lighter and pinker
  Eigen::Vector3f nail{0.82f, 0.56f, 0.50f};       // finger nails
  Eigen::Vector3f sleeve{0.018f, 0.018f, 0.021f};  // black sleeve
  // Per finger (thumb..pinky): a small factor on the skin albedo, so regions differ slightly.
  std::array<float, kNumFingers> finger_tint{{0.97f, 1.0f, 1.02f, 0.99f, 0.96f}};
};

struct HandSurfaceParams {
  SkinAlbedo skin;
  // Radii in metres at HandShape scale 1 and thickness 1, per finger (thumb..pinky), at the
  // proximal joint of each of the 3 bones and at the fingertip. For the thumb the first bone is
  // the metacarpal.
  std::array<std::array<double, 4>, kNumFingers> finger_radii{{
      {{0.0125, 0.0105, 0.0095, 0.0082}},
      {{0.0097, 0.0088, 0.0079, 0.0070}},
      {{0.0100, 0.0091, 0.0082, 0.0072}},
      {{0.0095, 0.0085, 0.0077, 0.0068}},
      {{0.0086, 0.0076, 0.0068, 0.0060}},
  }};
  double palm_radius = 0.0115;  // half the thickness of the palm slab
  double nail_length = 0.011;   // along the distal bone, from the fingertip
  // Forearm: it leaves the wrist backwards along the palm axis, bent towards the body.
  Eigen::Vector3d body_direction{0.0, -1.0, -0.3};  // root frame: where the elbow is
  double forearm_bend = 0.5;  // 0: straight on from the palm, larger: towards the body
  // The bare wrist: two capsules side by side (radius and ulna), `wrist_spread` either side of
  // the forearm axis across the palm.
  double wrist_radius = 0.0155;
  double wrist_spread = 0.008;
  // Distance from the wrist joint where the sleeve begins: the cuff sits at the wrist crease, as
  // in the paper's set-up (a black sleeve hides the arm). A 4.5 cm band of bare wrist skin, which
  // the 17-Gaussian model does not cover, pulls the fitted hand ~12 mm toward the arm.
  double sleeve_start = 0.012;
  double sleeve_radius = 0.031;  // at the cuff; it widens towards the elbow
  double sleeve_end_radius = 0.040;
  double forearm_length = 0.30;
  // A bare forearm (issue 9: users do not wear the paper's black sleeve): skin from the wrist to
  // `bare_forearm_length` from it, radius `forearm_radius` there growing to
  // `forearm_end_radius`; the sleeve then covers only the elbow region beyond.
  bool bare_forearm = false;
  double bare_forearm_length = 0.24;
  double forearm_radius = 0.021;
  double forearm_end_radius = 0.031;
};

// One surface primitive with its material.
struct SurfacePart {
  enum class Kind { kRoundCone, kSweptPolygon };
  Kind kind = Kind::kRoundCone;
  RoundCone cone;
  SweptPolygon polygon;
  std::uint8_t label = kLabelBackground;
  Eigen::Vector3f albedo_dorsal = Eigen::Vector3f::Zero();
  Eigen::Vector3f albedo_palmar = Eigen::Vector3f::Zero();  // where normal . dorsal < 0
  Eigen::Vector3d dorsal = Eigen::Vector3d::Zero();         // unit, or zero: dorsal albedo only
  // Distal phalanges: the nail covers the dorsal side beyond `nail_from` metres along the axis
  // from cone.a; negative: no nail.
  double nail_from = -1.0;
  Eigen::Vector3f albedo_nail = Eigen::Vector3f::Zero();
};

// The hand surface for posed bone frames (forwardKinematics(model, pose).bone_frames), in the
// root frame. `model` is the shaped model that produced the frames (shapeHandModel(.., shape));
// `shape` scales the radii (scale * thickness) and the forearm and nail lengths (scale).
std::vector<SurfacePart> buildHandSurface(const HandModel& model,
                                          const std::vector<Eigen::Isometry3d>& bone_frames,
                                          const HandSurfaceParams& params,
                                          const HandShape& shape = HandShape());

}  // namespace studio
}  // namespace sag_hand_tracker
