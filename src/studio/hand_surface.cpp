#include "sag_hand_tracker/studio/hand_surface.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace studio {

namespace {

bool hasChildren(const HandModel& model, int bone) {
  for (const Bone& b : model.bones) {
    if (b.parent == bone) return true;
  }
  return false;
}

int distalBoneByName(const HandModel& model, int finger) {
  int found = -1;
  for (size_t b = 1; b < model.bones.size(); ++b) {
    if (model.bones[b].name.find(fingerNames()[finger]) == std::string::npos) continue;
    if (hasChildren(model, static_cast<int>(b))) continue;
    if (found >= 0) return -1;  // ambiguous
    found = static_cast<int>(b);
  }
  return found;
}

Eigen::Vector3d palmPoint(const Eigen::Isometry3d& palm, double x, double y, double z) {
  return palm * Eigen::Vector3d(x, y, z);
}

}  // namespace

bool isSkinLabel(std::uint8_t label) { return label >= kLabelForearm; }

std::array<std::vector<int>, kNumFingers> fingerChains(const HandModel& model) {
  if (model.bones.empty() || model.bones[0].parent != -1) {
    throw InputError("hand model '" + model.name + "': bones[0] must be the palm (the root)");
  }
  std::array<std::vector<int>, kNumFingers> chains;
  for (int f = 0; f < kNumFingers; ++f) {
    int distal = -1;
    const int g = model.fingertip_gaussians[f];
    if (g >= 0 && g < static_cast<int>(model.gaussians.size())) {
      distal = model.gaussians[g].bone;
    } else {
      distal = distalBoneByName(model, f);
    }
    if (distal <= 0 || distal >= static_cast<int>(model.bones.size())) {
      throw InputError("hand model '" + model.name + "': cannot find the distal bone of the " +
                       fingerNames()[f]);
    }
    std::vector<int> chain;
    for (int b = distal; b != 0; b = model.bones[b].parent) {
      if (b < 0 || static_cast<int>(chain.size()) > 8) {
        throw InputError("hand model '" + model.name + "': the " + fingerNames()[f] +
                         " is not attached to the palm");
      }
      chain.push_back(b);
    }
    std::reverse(chain.begin(), chain.end());
    if (chain.size() != 3) {
      std::ostringstream msg;
      msg << "hand model '" << model.name << "': the " << fingerNames()[f] << " has "
          << chain.size() << " bones, the studio renders fingers of 3";
      throw InputError(msg.str());
    }
    chains[f] = chain;
  }
  return chains;
}

HandModel shapeHandModel(const HandModel& model, const HandShape& shape) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  bool ok = positive(shape.scale) && positive(shape.palm_width) && positive(shape.palm_length) &&
            positive(shape.thickness);
  for (double f : shape.finger_length) ok = ok && positive(f);
  for (const auto& finger : shape.phalanx_length) {
    for (double f : finger) ok = ok && positive(f);
  }
  if (!ok) throw InputError("hand shape: every scale factor must be positive and finite");
  for (int f = 0; f < kNumFingers; ++f) {
    if (!shape.knuckle_shift[f].allFinite() || !shape.base_rotation[f].allFinite() ||
        !std::isfinite(shape.flexion_tilt[f])) {
      throw InputError(std::string("hand shape: the ") + fingerNames()[f] +
                       "'s knuckle shift, base rotation and flexion tilt must be finite");
    }
  }

  const auto chains = fingerChains(model);
  HandModel out = model;
  // Per bone: the factor on its length and on its children's offsets along it, and across it.
  std::vector<double> factor(model.bones.size(), shape.scale);
  std::vector<double> across(model.bones.size(), shape.scale);
  for (int f = 0; f < kNumFingers; ++f) {
    for (int k = 0; k < 3; ++k) {
      factor[chains[f][k]] = shape.boneFactor(f, k);
      across[chains[f][k]] = shape.scale * shape.finger_length[f];
    }
  }
  const Eigen::Vector3d palm_factor(shape.scale * shape.palm_length, shape.scale * shape.palm_width,
                                    shape.scale);
  for (size_t b = 0; b < out.bones.size(); ++b) {
    Bone& bone = out.bones[b];
    bone.length *= factor[b];
    if (bone.parent < 0) {
      continue;  // the root's offset is the pose
    } else if (bone.parent == 0) {
      bone.offset = bone.offset.cwiseProduct(palm_factor);
    } else {
      bone.offset *= factor[bone.parent];  // the parent's length
    }
  }
  for (ModelGaussian& g : out.gaussians) {
    if (g.bone < 0 || g.bone >= static_cast<int>(out.bones.size())) continue;
    Eigen::Vector3d s(factor[g.bone], across[g.bone], across[g.bone]);
    if (g.bone == 0) s = palm_factor;
    g.mean = g.mean.cwiseProduct(s);
    g.cov = s.asDiagonal() * g.cov * s.asDiagonal();
  }
  for (int f = 0; f < kNumFingers; ++f) {
    Bone& first = out.bones[chains[f][0]];
    first.offset += shape.scale * shape.knuckle_shift[f];
    first.rest_rotation = first.rest_rotation * rpyRotation(shape.base_rotation[f]);
    const Eigen::AngleAxisd tilt(shape.flexion_tilt[f], Eigen::Vector3d::UnitX());
    for (const int bone : chains[f]) {
      for (const int dof : out.bones[bone].joint_dofs) {
        Eigen::Vector3d& axis = out.joints[dof].axis;
        if (std::abs(axis.y()) > 0.9) axis = tilt * axis;  // a flexion axis
      }
    }
  }
  return out;
}

Fingertips boneFingertips(const HandModel& model,
                          const std::vector<Eigen::Isometry3d>& bone_frames) {
  const auto chains = fingerChains(model);
  Fingertips tips;
  for (int f = 0; f < kNumFingers; ++f) {
    const int distal = chains[f].back();
    const Eigen::Isometry3d& frame = bone_frames.at(distal);
    tips[f] = frame.translation() + model.bones[distal].length * frame.linear().col(0);
  }
  return tips;
}

std::vector<SurfacePart> buildHandSurface(const HandModel& model,
                                          const std::vector<Eigen::Isometry3d>& bone_frames,
                                          const HandSurfaceParams& params, const HandShape& shape) {
  if (bone_frames.size() != model.bones.size()) {
    throw InputError("buildHandSurface: bone frames do not match the model");
  }
  const auto chains = fingerChains(model);
  const double rs = shape.scale * shape.thickness;  // radius scale
  const double ls = shape.scale;                    // length scale
  const SkinAlbedo& skin = params.skin;
  std::vector<SurfacePart> parts;
  parts.reserve(24);

  auto skinPart = [&](const RoundCone& cone, std::uint8_t label, const Eigen::Vector3d& dorsal,
                      float tint) {
    SurfacePart part;
    part.kind = SurfacePart::Kind::kRoundCone;
    part.cone = cone;
    part.label = label;
    part.albedo_dorsal = skin.dorsal * tint;
    part.albedo_palmar = skin.palmar * tint;
    part.albedo_nail = skin.nail;
    part.dorsal = dorsal;
    return part;
  };

  // Fingers: one tapered capsule per bone; consecutive capsules share their joint sphere.
  for (int f = 0; f < kNumFingers; ++f) {
    const auto& radii = params.finger_radii[f];
    for (int k = 0; k < 3; ++k) {
      const int bone = chains[f][k];
      const Eigen::Isometry3d& frame = bone_frames[bone];
      const Eigen::Vector3d x = frame.linear().col(0);
      const double length = model.bones[bone].length;
      RoundCone cone;
      cone.a = frame.translation();
      cone.ra = radii[k] * rs;
      cone.rb = radii[k + 1] * rs;
      if (k < 2) {
        cone.b = bone_frames[chains[f][k + 1]].translation();
      } else {
        // The cap ends exactly at the fingertip (the bone's end); a fingertip shorter than its
        // radius becomes a sphere touching the tip.
        cone.rb = std::min(cone.rb, 0.5 * length);
        cone.b = cone.a + (length - cone.rb) * x;
      }
      SurfacePart part =
          skinPart(cone, fingerBoneLabel(f, k), frame.linear().col(2), skin.finger_tint[f]);
      if (k == 2) part.nail_from = std::max(0.0, length - params.nail_length * ls);
      parts.push_back(part);
    }
  }

  // Palm: a rounded slab through the knuckles and the wrist, metacarpal ridges to the knuckles
  // and the thenar eminence between the palm and the thumb's metacarpal.
  const Eigen::Isometry3d& palm = bone_frames[0];
  const Eigen::Isometry3d palm_inv = palm.inverse();
  const Eigen::Vector3d palm_z = palm.linear().col(2);
  std::array<Eigen::Vector3d, kNumFingers> base;  // first joint of each finger, palm frame
  for (int f = 0; f < kNumFingers; ++f)
    base[f] = palm_inv * bone_frames[chains[f][0]].translation();
  const double r_palm = params.palm_radius * rs;
  const double y_radial = base[1].y();  // index side
  const double y_ulnar = base[4].y();   // pinky side
  std::vector<Eigen::Vector2d> outline;
  for (int f = 1; f < kNumFingers; ++f) {
    outline.emplace_back(base[f].x() - 0.4 * r_palm, base[f].y());
  }
  outline.emplace_back(0.25 * r_palm, 0.6 * y_radial);
  outline.emplace_back(0.25 * r_palm, 0.6 * y_ulnar);
  outline.emplace_back(0.5 * base[4].x(), 1.02 * y_ulnar);
  outline.emplace_back(0.5 * base[1].x(), 0.95 * y_radial);
  SurfacePart slab = skinPart(RoundCone(), kLabelPalm, palm_z, 1.0f);
  slab.kind = SurfacePart::Kind::kSweptPolygon;
  slab.polygon.origin = palmPoint(palm, 0.0, 0.0, -0.15 * r_palm);
  slab.polygon.u = palm.linear().col(0);
  slab.polygon.v = palm.linear().col(1);
  slab.polygon.vertices = convexHull(outline);
  slab.polygon.radius = r_palm;
  if (slab.polygon.vertices.size() < 3) {
    throw InputError("hand model '" + model.name + "': the knuckles do not span a palm");
  }
  if (y_radial < y_ulnar) {  // a mirrored (left) hand: keep the polygon counter-clockwise
    slab.polygon.v = -slab.polygon.v;
    for (auto& v : slab.polygon.vertices) v.y() = -v.y();
    slab.polygon.vertices = convexHull(slab.polygon.vertices);
  }
  parts.push_back(slab);
  for (int f = 1; f < kNumFingers; ++f) {
    RoundCone ridge{palmPoint(palm, 0.3 * base[f].x(), 0.7 * base[f].y(), 0.0), palm * base[f],
                    0.85 * r_palm, params.finger_radii[f][0] * 1.02 * rs};
    parts.push_back(skinPart(ridge, kLabelPalm, palm_z, 1.0f));
  }
  {
    const Eigen::Vector3d thumb_mid =
        0.5 * (bone_frames[chains[0][0]].translation() + bone_frames[chains[0][1]].translation());
    RoundCone thenar{palmPoint(palm, 0.35 * base[1].x(), 0.5 * y_radial, -0.3 * r_palm), thumb_mid,
                     1.1 * r_palm, params.finger_radii[0][0] * rs};
    parts.push_back(skinPart(thenar, kLabelPalm, palm_z, 1.0f));
  }

  // Forearm: bare wrist, then the black sleeve.
  const Eigen::Vector3d wrist = palm.translation();
  Eigen::Vector3d direction = -palm.linear().col(0);
  if (params.body_direction.norm() > 0.0) {
    direction += params.forearm_bend * params.body_direction.normalized();
  }
  if (direction.norm() < 1e-6) direction = -palm.linear().col(0);
  direction.normalize();
  Eigen::Vector3d across = palm.linear().col(1) - palm.linear().col(1).dot(direction) * direction;
  across = across.norm() > 1e-6 ? across.normalized() : direction.unitOrthogonal();
  for (const double side : {1.0, -1.0}) {
    const Eigen::Vector3d offset = side * params.wrist_spread * ls * across;
    RoundCone wrist_cone{wrist + 0.004 * ls * direction + offset - 0.15 * r_palm * palm_z,
                         wrist + (params.sleeve_start + 0.01) * ls * direction + 0.9 * offset,
                         params.wrist_radius * rs, params.wrist_radius * 1.05 * rs};
    parts.push_back(skinPart(wrist_cone, kLabelForearm, Eigen::Vector3d::Zero(), 1.0f));
  }
  double sleeve_from = params.sleeve_start;
  double sleeve_radius = params.sleeve_radius;
  if (params.bare_forearm) {
    // The forearm in skin, its palmar side (inner arm) lighter as on the hand; the sleeve starts
    // near the elbow.
    RoundCone arm{wrist + (params.sleeve_start + 0.005) * ls * direction,
                  wrist + params.bare_forearm_length * ls * direction, params.forearm_radius * rs,
                  params.forearm_end_radius * rs};
    parts.push_back(skinPart(arm, kLabelForearm, palm_z, 1.0f));
    sleeve_from = params.bare_forearm_length;
    sleeve_radius = std::max(params.sleeve_radius, params.forearm_end_radius + 0.004);
  }
  SurfacePart sleeve;
  sleeve.cone = RoundCone{wrist + sleeve_from * ls * direction,
                          wrist + params.forearm_length * ls * direction, sleeve_radius * rs,
                          std::max(sleeve_radius, params.sleeve_end_radius) * rs};
  sleeve.label = kLabelSleeve;
  sleeve.albedo_dorsal = skin.sleeve;
  sleeve.albedo_palmar = skin.sleeve;
  parts.push_back(sleeve);
  return parts;
}

}  // namespace studio
}  // namespace sag_hand_tracker
