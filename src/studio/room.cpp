// Studio rooms (room.h): props, photographs and changing light around the studio's hand.
#include "sag_hand_tracker/studio/room.h"

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sag_hand_tracker/model/kinematics.h"
#include "sag_hand_tracker/model/pose.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace studio {
namespace {

SurfacePart prop(const RoundCone& cone, const Eigen::Vector3f& albedo) {
  SurfacePart part;
  part.kind = SurfacePart::Kind::kRoundCone;
  part.cone = cone;
  part.label = kLabelProp;
  part.albedo_dorsal = albedo;
  part.albedo_palmar = albedo;
  return part;
}

// A rounded box lying on the table: its top face (size_x x size_y, at height `height`) swept by
// a sphere of radius height / 2.
SurfacePart boxProp(const Eigen::Vector2d& centre, double size_x, double size_y, double height,
                    const Eigen::Vector3f& albedo) {
  SurfacePart part;
  part.kind = SurfacePart::Kind::kSweptPolygon;
  const double r = 0.5 * height;
  part.polygon.origin = Eigen::Vector3d(centre.x(), centre.y(), r);
  part.polygon.radius = r;
  const double hx = std::max(0.5 * size_x - r, 0.001), hy = std::max(0.5 * size_y - r, 0.001);
  part.polygon.vertices = {{-hx, -hy}, {hx, -hy}, {hx, hy}, {-hx, hy}};
  part.label = kLabelProp;
  part.albedo_dorsal = albedo;
  part.albedo_palmar = albedo;
  return part;
}

cv::Mat loadPhoto(const std::string& name, const std::string& config_dir) {
  if (name.empty()) return cv::Mat();
  const std::string path = (std::filesystem::path(config_dir) / "studio" / name).string();
  cv::Mat bgr = cv::imread(path, cv::IMREAD_COLOR);
  if (bgr.empty()) throw InputError("studio room: cannot read the photograph " + path);
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  return rgb;
}

}  // namespace

const std::vector<std::string>& builtinRoomNames() {
  static const std::vector<std::string> names{"office", "kitchen", "daylight"};
  return names;
}

RoomParams builtinRoom(const std::string& name) {
  RoomParams room;
  room.name = name;
  if (name == "office") {
    // A portrait (a face and an orange suit) tiled on the walls, a face behind the workspace,
    // wooden things on the desk; a plate can be learned.
    room.wall_photo = "astronaut.jpg";
    room.face = true;
    room.wood_objects = true;
  } else if (name == "kitchen") {
    // A wooden table top (photograph), a ginger cat on the walls, the other arm, skin-coloured
    // things, dimming light, and the hand in view from the first frame: the skin gate only.
    room.table_photo = "coffee.jpg";
    room.wall_photo = "chelsea.jpg";
    room.second_arm = true;
    room.skin_objects = true;
    room.light_change = 0.25;
    room.hand_free_frames = false;
  } else if (name == "daylight") {
    // Everything at once, with light that dims by 35 % after the plate was learned.
    room.wall_photo = "brick.jpg";
    room.face = true;
    room.second_arm = true;
    room.skin_objects = true;
    room.wood_objects = true;
    room.light_change = 0.35;
  } else {
    std::string known;
    for (const std::string& n : builtinRoomNames()) known += (known.empty() ? "" : ", ") + n;
    throw InputError("unknown studio room '" + name + "' (known: " + known + ")");
  }
  return room;
}

StudioRoom::StudioRoom(const RoomParams& params, const HandModel& model,
                       const std::string& config_dir)
    : params_(params), model_(model) {
  if (!(params_.light_change >= 0.0 && params_.light_change < 1.0)) {
    throw InputError("studio room '" + params_.name + "': light_change must be in [0, 1)");
  }
  if (!(params_.light_period > 0.0)) {
    throw InputError("studio room '" + params_.name + "': light_period must be positive");
  }
  table_photo_ = loadPhoto(params_.table_photo, config_dir);
  wall_photo_ = loadPhoto(params_.wall_photo, config_dir);
}

StudioSceneParams StudioRoom::scene(StudioSceneParams base) const {
  base.table_photo = table_photo_;
  base.wall_photo = wall_photo_;
  return base;
}

double StudioRoom::lightGain(double time) const {
  return 1.0 -
         params_.light_change * 0.5 * (1.0 - std::cos(2.0 * M_PI * time / params_.light_period));
}

std::vector<SurfacePart> StudioRoom::props(double time) const {
  std::vector<SurfacePart> parts;
  if (params_.face) {
    // A head behind the workspace on the user's side (-y), above the forearm: skin a little
    // pinker than the hand's, and a neck.
    RoundCone head{{0.02, -0.66, 0.40}, {0.02, -0.66, 0.47}, 0.075, 0.07};
    parts.push_back(prop(head, Eigen::Vector3f(0.74f, 0.43f, 0.33f)));
    RoundCone neck{{0.02, -0.68, 0.25}, {0.02, -0.67, 0.36}, 0.05, 0.045};
    parts.push_back(prop(neck, Eigen::Vector3f(0.68f, 0.40f, 0.30f)));
  }
  if (params_.skin_objects) {
    RoundCone ball{{-0.30, 0.22, 0.04}, {-0.30, 0.22, 0.0401}, 0.04, 0.04};
    parts.push_back(prop(ball, Eigen::Vector3f(0.80f, 0.42f, 0.33f)));
    parts.push_back(boxProp({0.30, 0.25}, 0.16, 0.11, 0.07, Eigen::Vector3f(0.52f, 0.36f, 0.19f)));
  }
  if (params_.wood_objects) {
    parts.push_back(
        boxProp({-0.28, -0.15}, 0.10, 0.14, 0.05, Eigen::Vector3f(0.50f, 0.27f, 0.11f)));
    RoundCone rod{{-0.05, 0.33, 0.015}, {0.22, 0.30, 0.015}, 0.014, 0.014};
    parts.push_back(prop(rod, Eigen::Vector3f(0.62f, 0.40f, 0.20f)));
  }
  if (params_.second_arm) {
    // The other hand rests palm down on the table to the right, fingers away from the user,
    // drifting slowly.
    Eigen::Matrix3d rotation;
    rotation.col(0) = Eigen::Vector3d::UnitY();
    rotation.col(2) = Eigen::Vector3d::UnitZ();
    rotation.col(1) = rotation.col(2).cross(rotation.col(0));
    const Eigen::Vector3d wrist(0.34 + 0.03 * std::sin(2.0 * M_PI * time / 5.0),
                                -0.20 + 0.02 * std::sin(2.0 * M_PI * time / 7.0), 0.024);
    Pose pose = neutralPose(model_, wrist, rotation);
    pose.joints.setConstant(0.15);  // relaxed, slightly curled
    const PosedHand posed = forwardKinematics(model_, pose);
    for (SurfacePart part : buildHandSurface(model_, posed.bone_frames, HandSurfaceParams())) {
      part.label = kLabelProp;
      parts.push_back(part);
    }
  }
  return parts;
}

void StudioRoom::addProps(std::vector<std::vector<SurfacePart>>* subframes, double time) const {
  const std::vector<SurfacePart> room_props = props(time);
  if (room_props.empty()) return;
  if (subframes->empty()) subframes->emplace_back();
  for (auto& parts : *subframes) parts.insert(parts.end(), room_props.begin(), room_props.end());
}

}  // namespace studio
}  // namespace sag_hand_tracker
