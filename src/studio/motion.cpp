#include "sag_hand_tracker/studio/motion.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <sstream>

#include "sag_hand_tracker/studio/renderer.h"  // mixSeed
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace studio {

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr int kChannels = 6 + kNumJointDof;  // position, orientation, joints
// Keyframe values may sit on a limit written in degrees with a few decimals.
constexpr double kLimitTolerance = 1e-6;

class Parser {
 public:
  Parser(std::string source, const HandModel& model) : source_(std::move(source)), model_(model) {
    const std::vector<std::string> names = model.parameterNames();
    for (int j = 0; j < kNumJointDof; ++j) {
      joint_index_[names.at(kFirstJointDof + j)] = j;
    }
  }

  [[noreturn]] void fail(const YAML::Node& node, const std::string& problem) const {
    std::ostringstream msg;
    msg << "motion " << source_;
    if (node.IsDefined() && node.Mark().line >= 0) msg << ":" << node.Mark().line + 1;
    msg << ": " << problem;
    throw InputError(msg.str());
  }
  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError("motion " + source_ + ": " + problem);
  }

  void checkKeys(const YAML::Node& map, const std::set<std::string>& allowed,
                 const std::string& where) const {
    if (!map.IsMap()) fail(map, where + " must be a map");
    for (const auto& item : map) {
      const std::string key = item.first.as<std::string>();
      if (!allowed.count(key)) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        fail(item.first,
             "unknown key '" + key + "' in " + where + " (expected one of: " + list + ")");
      }
    }
  }

  double number(const YAML::Node& node, const std::string& what) const {
    if (!node.IsDefined()) fail(what + " is missing");
    if (!node.IsScalar()) fail(node, what + " must be a number");
    double value;
    try {
      value = node.as<double>();
    } catch (const YAML::Exception&) {
      fail(node, what + " must be a number, not '" + node.as<std::string>() + "'");
    }
    if (!std::isfinite(value)) fail(node, what + " must be finite");
    return value;
  }

  Eigen::Vector3d vector3(const YAML::Node& node, const std::string& what) const {
    if (!node.IsSequence() || node.size() != 3) fail(node, what + " must be a list of 3 numbers");
    return Eigen::Vector3d(number(node[0], what), number(node[1], what), number(node[2], what));
  }

  int jointIndex(const YAML::Node& key) const {
    const std::string name = key.as<std::string>();
    const auto it = joint_index_.find(name);
    if (it == joint_index_.end()) {
      std::string list;
      for (int j = 0; j < kNumJointDof; ++j) {
        list += (j ? ", " : "") + model_.parameterNames()[kFirstJointDof + j];
      }
      fail(key, "unknown joint '" + name + "' (the model's joints are: " + list + ")");
    }
    return it->second;
  }

  // Joint angles in degrees -> (index, radians).
  std::map<int, double> joints(const YAML::Node& node, const std::string& what) const {
    std::map<int, double> out;
    if (!node.IsMap()) fail(node, what + " must be a map of joint names to degrees");
    for (const auto& item : node) {
      out[jointIndex(item.first)] =
          number(item.second, what + " " + item.first.as<std::string>()) * kDeg;
    }
    return out;
  }

  void checkLimits(const JointVector& q, const YAML::Node& node, const std::string& what) const {
    for (int j = 0; j < kNumJointDof; ++j) {
      const JointDof& dof = model_.joints[j];
      if (q[j] < dof.min - kLimitTolerance || q[j] > dof.max + kLimitTolerance) {
        std::ostringstream msg;
        msg << what << ": joint " << model_.parameterNames()[kFirstJointDof + j] << " = "
            << q[j] / kDeg << " deg is outside its limits [" << dof.min / kDeg << ", "
            << dof.max / kDeg << "] deg";
        fail(node, msg.str());
      }
    }
  }

 private:
  std::string source_;
  const HandModel& model_;
  std::map<std::string, int> joint_index_;
};

// Monotone piecewise-cubic Hermite interpolation (PCHIP) of one channel: C1, no overshoot, so
// holds stay holds and values stay between their keyframes.
double pchip(const std::vector<double>& t, const std::vector<double>& y, double x) {
  const size_t n = t.size();
  if (n == 1 || x <= t.front()) return y.front();
  if (x >= t.back()) return y.back();
  const size_t i = std::upper_bound(t.begin(), t.end(), x) - t.begin() - 1;
  auto slope = [&](size_t k) { return (y[k + 1] - y[k]) / (t[k + 1] - t[k]); };
  auto tangent = [&](size_t k) {
    if (k == 0 || k == n - 1) return 0.0;
    const double d0 = slope(k - 1), d1 = slope(k);
    if (d0 * d1 <= 0.0) return 0.0;
    const double h0 = t[k] - t[k - 1], h1 = t[k + 1] - t[k];
    const double w0 = 2.0 * h1 + h0, w1 = h1 + 2.0 * h0;
    return (w0 + w1) / (w0 / d0 + w1 / d1);
  };
  const double h = t[i + 1] - t[i];
  const double s = (x - t[i]) / h;
  const double s2 = s * s, s3 = s2 * s;
  return (2 * s3 - 3 * s2 + 1) * y[i] + (s3 - 2 * s2 + s) * h * tangent(i) +
         (-2 * s3 + 3 * s2) * y[i + 1] + (s3 - s2) * h * tangent(i + 1);
}

double linear(const std::vector<double>& t, const std::vector<double>& y, double x) {
  if (t.size() == 1 || x <= t.front()) return y.front();
  if (x >= t.back()) return y.back();
  const size_t i = std::upper_bound(t.begin(), t.end(), x) - t.begin() - 1;
  const double s = (x - t[i]) / (t[i + 1] - t[i]);
  return (1 - s) * y[i] + s * y[i + 1];
}

// All channels of a keyframe in one vector: position, orientation (deg), joints (rad).
Eigen::Matrix<double, kChannels, 1> channels(const MotionKeyframe& k) {
  Eigen::Matrix<double, kChannels, 1> c;
  c << k.position, k.orientation, k.joints;
  return c;
}

Eigen::Matrix<double, kChannels, 1> interpolate(const std::vector<MotionKeyframe>& keys, bool cubic,
                                                double time) {
  std::vector<double> t(keys.size()), y(keys.size());
  for (size_t k = 0; k < keys.size(); ++k) t[k] = keys[k].time;
  Eigen::Matrix<double, kChannels, 1> out;
  for (int c = 0; c < kChannels; ++c) {
    for (size_t k = 0; k < keys.size(); ++k) y[k] = channels(keys[k])[c];
    out[c] = cubic ? pchip(t, y, time) : linear(t, y, time);
  }
  return out;
}

std::uint64_t nameHash(const std::string& name) {
  std::uint64_t h = 1469598103934665603ULL;  // FNV-1a
  for (unsigned char c : name) h = (h ^ c) * 1099511628211ULL;
  return h;
}

std::string baseName(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  const size_t dot = name.find_last_of('.');
  return dot == std::string::npos ? name : name.substr(0, dot);
}

}  // namespace

double MotionJitter::value(int channel, double time) const {
  if (channels.empty()) return 0.0;
  double sum = 0.0;
  for (const Wave& w : channels[channel]) {
    sum += w.amplitude * std::sin(2.0 * M_PI * w.frequency * time + w.phase);
  }
  return sum;
}

Eigen::Matrix3d motionOrientation(const Eigen::Vector3d& rpy) {
  return (Eigen::AngleAxisd(M_PI / 2 + rpy.z() * kDeg, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(rpy.y() * kDeg, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rpy.x() * kDeg, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Pose Motion::poseAt(double time) const {
  Eigen::Matrix<double, kChannels, 1> c = interpolate(keyframes, cubic, time);
  for (int k = 0; k < kChannels; ++k) c[k] += jitter.value(k, time);
  Pose pose;
  pose.translation = c.segment<3>(0);
  pose.rotation = motionOrientation(c.segment<3>(3));
  pose.joints = c.segment<kNumJointDof>(6).cwiseMax(joint_min).cwiseMin(joint_max);
  return pose;
}

Motion parseMotion(const std::string& yaml_text, const std::string& source, const HandModel& model,
                   std::uint64_t seed) {
  if (static_cast<int>(model.joints.size()) != kNumJointDof) {
    throw InputError("motion " + source + ": the hand model has " +
                     std::to_string(model.joints.size()) + " joints, expected " +
                     std::to_string(kNumJointDof));
  }
  Parser parser(source, model);
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw InputError("motion " + source + ":" + std::to_string(e.mark.line + 1) +
                     ": not valid YAML: " + e.msg);
  }
  if (!root.IsMap()) parser.fail("the document must be a map with a 'keyframes' list");
  parser.checkKeys(root,
                   {"name", "description", "duration", "interpolation", "shapes", "keyframes",
                    "random", "forearm"},
                   "the motion");

  Motion motion;
  motion.source = source;
  motion.name = root["name"] ? root["name"].as<std::string>() : baseName(source);
  if (root["description"]) motion.description = root["description"].as<std::string>();
  for (int j = 0; j < kNumJointDof; ++j) {
    motion.joint_min[j] = model.joints[j].min;
    motion.joint_max[j] = model.joints[j].max;
  }
  if (root["interpolation"]) {
    const std::string mode = root["interpolation"].as<std::string>();
    if (mode == "cubic") {
      motion.cubic = true;
    } else if (mode == "linear") {
      motion.cubic = false;
    } else {
      parser.fail(root["interpolation"],
                  "interpolation must be 'cubic' or 'linear', not '" + mode + "'");
    }
  }

  if (const YAML::Node forearm = root["forearm"]) {
    parser.checkKeys(forearm, {"bare", "bend"}, "forearm");
    if (const YAML::Node bare = forearm["bare"]) {
      try {
        motion.bare_forearm = bare.as<bool>();
      } catch (const YAML::Exception&) {
        parser.fail(bare, "forearm bare must be true or false");
      }
    }
    if (forearm["bend"]) {
      motion.forearm_bend = parser.number(forearm["bend"], "forearm bend");
      if (*motion.forearm_bend < 0.0 || *motion.forearm_bend > 10.0) {
        parser.fail(forearm["bend"], "forearm bend must lie in [0, 10]");
      }
    }
  }

  std::map<std::string, std::map<int, double>> shapes;
  if (const YAML::Node node = root["shapes"]) {
    if (!node.IsMap()) parser.fail(node, "shapes must be a map of shape names to joint maps");
    for (const auto& item : node) {
      const std::string name = item.first.as<std::string>();
      shapes[name] = parser.joints(item.second, "shape '" + name + "'");
    }
  }

  const YAML::Node keys = root["keyframes"];
  if (!keys) parser.fail("'keyframes' is missing");
  if (!keys.IsSequence() || keys.size() == 0) {
    parser.fail(keys, "keyframes must be a non-empty list");
  }
  JointVector current;
  for (int j = 0; j < kNumJointDof; ++j) {
    current[j] = std::clamp(0.0, model.joints[j].min, model.joints[j].max);
  }
  for (size_t k = 0; k < keys.size(); ++k) {
    const YAML::Node node = keys[k];
    const std::string what = "keyframe " + std::to_string(k + 1);
    parser.checkKeys(node, {"time", "position", "orientation", "shape", "joints"}, what);
    MotionKeyframe key;
    key.time = parser.number(node["time"], what + " time");
    if (key.time < 0.0) parser.fail(node["time"], what + ": time must not be negative");
    if (k > 0 && key.time <= motion.keyframes.back().time) {
      parser.fail(node["time"], what + ": times must increase strictly (" +
                                    std::to_string(key.time) + " s follows " +
                                    std::to_string(motion.keyframes.back().time) + " s)");
    }
    if (!node["position"] && k == 0) parser.fail(node, what + ": position is missing");
    key.position = node["position"] ? parser.vector3(node["position"], what + " position")
                                    : motion.keyframes.back().position;
    key.orientation =
        node["orientation"]
            ? parser.vector3(node["orientation"], what + " orientation")
            : (k == 0 ? Eigen::Vector3d::Zero().eval() : motion.keyframes.back().orientation);
    if (const YAML::Node shape = node["shape"]) {
      const std::string name = shape.as<std::string>();
      const auto it = shapes.find(name);
      if (it == shapes.end()) parser.fail(shape, what + ": unknown shape '" + name + "'");
      for (const auto& [j, value] : it->second) current[j] = value;
    }
    if (const YAML::Node joints = node["joints"]) {
      for (const auto& [j, value] : parser.joints(joints, what + " joints")) current[j] = value;
    }
    parser.checkLimits(current, node, what + " (t = " + std::to_string(key.time) + " s)");
    key.joints = current;
    motion.keyframes.push_back(key);
  }
  motion.duration = motion.keyframes.back().time;
  if (root["duration"]) {
    motion.duration = parser.number(root["duration"], "duration");
    if (motion.duration <= 0.0) parser.fail(root["duration"], "duration must be positive");
  }
  if (motion.duration <= 0.0) {
    parser.fail("duration is zero: give 'duration' or keyframes that span some time");
  }

  const std::uint64_t motion_seed = mixSeed(seed, nameHash(motion.name));
  std::mt19937_64 rng(motion_seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  if (const YAML::Node random = root["random"]) {
    parser.checkKeys(random, {"keyframes", "jitter"}, "random");
    if (const YAML::Node blocks = random["keyframes"]) {
      // One block (a map) or several (a list of maps), each over its own time span.
      std::vector<YAML::Node> gens;
      if (blocks.IsSequence()) {
        for (const YAML::Node& b : blocks) gens.push_back(b);
      } else {
        gens.push_back(blocks);
      }
      const std::vector<MotionKeyframe> base = motion.keyframes;
      std::vector<MotionKeyframe> drawn;
      for (const YAML::Node& gen : gens) {
        parser.checkKeys(gen, {"from", "to", "interval", "position", "orientation", "joints"},
                         "random keyframes");
        const double from = parser.number(gen["from"], "random keyframes from");
        const double to = parser.number(gen["to"], "random keyframes to");
        const double interval = parser.number(gen["interval"], "random keyframes interval");
        if (interval <= 0.0 || to < from || from < 0.0) {
          parser.fail(gen, "random keyframes need 0 <= from <= to and a positive interval");
        }
        const Eigen::Vector3d dp = gen["position"]
                                       ? parser.vector3(gen["position"], "random position")
                                       : Eigen::Vector3d::Zero().eval();
        const Eigen::Vector3d dr = gen["orientation"]
                                       ? parser.vector3(gen["orientation"], "random orientation")
                                       : Eigen::Vector3d::Zero().eval();
        const double fraction = gen["joints"] ? parser.number(gen["joints"], "random joints") : 0.0;
        if (fraction < 0.0 || fraction > 1.0) {
          parser.fail(gen["joints"], "random joints must be a fraction in [0, 1]");
        }
        const int count = static_cast<int>(std::floor((to - from) / interval + 1e-9)) + 1;
        for (int i = 0; i < count; ++i) {
          const double t = from + i * interval;
          bool near_other = false;
          for (const auto& b : base) near_other |= std::abs(b.time - t) < 0.5 * interval;
          for (const auto& d : drawn) near_other |= std::abs(d.time - t) < 0.5 * interval;
          // Draw even when skipping, so that the draws do not depend on the skips.
          MotionKeyframe key;
          key.time = t;
          key.random = true;
          const Eigen::Matrix<double, kChannels, 1> centre = interpolate(base, motion.cubic, t);
          for (int a = 0; a < 3; ++a) key.position[a] = centre[a] + dp[a] * unit(rng);
          for (int a = 0; a < 3; ++a) key.orientation[a] = centre[3 + a] + dr[a] * unit(rng);
          for (int j = 0; j < kNumJointDof; ++j) {
            const double lo = model.joints[j].min, hi = model.joints[j].max;
            const double mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo) * fraction;
            key.joints[j] = fraction > 0.0 ? mid + half * unit(rng) : centre[6 + j];
          }
          if (!near_other) drawn.push_back(key);
        }
      }
      motion.keyframes.insert(motion.keyframes.end(), drawn.begin(), drawn.end());
      std::sort(motion.keyframes.begin(), motion.keyframes.end(),
                [](const MotionKeyframe& a, const MotionKeyframe& b) { return a.time < b.time; });
    }
    if (const YAML::Node jitter = random["jitter"]) {
      parser.checkKeys(jitter, {"position", "orientation", "joints", "frequency"}, "random jitter");
      const double ap =
          jitter["position"] ? parser.number(jitter["position"], "jitter position") : 0.0;
      const double ao =
          jitter["orientation"] ? parser.number(jitter["orientation"], "jitter orientation") : 0.0;
      const double aj =
          jitter["joints"] ? parser.number(jitter["joints"], "jitter joints") * kDeg : 0.0;
      const double f =
          jitter["frequency"] ? parser.number(jitter["frequency"], "jitter frequency") : 1.0;
      if (ap < 0 || ao < 0 || aj < 0 || f <= 0) {
        parser.fail(jitter, "jitter amplitudes must be >= 0 and the frequency positive");
      }
      motion.jitter.channels.resize(kChannels);
      for (int c = 0; c < kChannels; ++c) {
        const double amplitude = c < 3 ? ap : (c < 6 ? ao : aj);
        for (int w = 0; w < 3; ++w) {
          MotionJitter::Wave wave;
          wave.amplitude = 0.5 * amplitude;
          wave.frequency = f * (1.0 + 0.5 * unit(rng));
          wave.phase = M_PI * (1.0 + unit(rng));
          motion.jitter.channels[c].push_back(wave);
        }
      }
    }
  }
  return motion;
}

Motion loadMotion(const std::string& path, const HandModel& model, std::uint64_t seed) {
  std::ifstream in(path);
  if (!in) throw InputError("motion " + path + ": cannot open the file");
  std::stringstream text;
  text << in.rdbuf();
  return parseMotion(text.str(), path, model, seed);
}

const std::vector<std::string>& builtinMotionNames() {
  static const std::vector<std::string> names{"adbadd", "fingercount", "fingerwave", "flexex1",
                                              "pinch",  "random",      "tigergrasp"};
  return names;
}

const std::vector<std::string>& hardMotionNames() {
  static const std::vector<std::string> names{"raised", "pronation", "wristflex", "fastturn"};
  return names;
}

std::string resolveMotionPath(const std::string& name_or_path, const std::string& config_dir) {
  for (const auto* names : {&builtinMotionNames(), &hardMotionNames()}) {
    if (std::find(names->begin(), names->end(), name_or_path) != names->end()) {
      return config_dir + "/motions/" + name_or_path + ".yaml";
    }
  }
  // Other motions in config/motions (calibration_routine) by name too; a path is taken as it is.
  const std::string in_config = config_dir + "/motions/" + name_or_path + ".yaml";
  if (name_or_path.find('/') == std::string::npos &&
      name_or_path.find('.') == std::string::npos && std::ifstream(in_config).good()) {
    return in_config;
  }
  return name_or_path;
}

}  // namespace studio
}  // namespace sag_hand_tracker
