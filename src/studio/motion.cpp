#include "sag_hand_tracker/studio/motion.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <random>
#include <set>
#include <sstream>

#include "sag_hand_tracker/studio/renderer.h"  // mixSeed
#include "sag_hand_tracker/util/number_text.h"
#include "sag_hand_tracker/util/types.h"
#include "sag_hand_tracker/util/yaml_reader.h"

namespace sag_hand_tracker {
namespace studio {

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr int kChannels = 6 + kNumJointDof;  // position, orientation, joints
// Keyframe values may sit on a limit written in degrees with a few decimals.
constexpr double kLimitTolerance = 1e-6;

// Ranges of keyframe values: a hand within 10 m of the origin, angles within two turns, keyframes
// at least 1 ms apart (interpolation divides by their spacing).
constexpr double kMaxPositionMetres = 10.0;
constexpr double kMaxAngleDegrees = 720.0;
constexpr double kMinKeyframeSpacing = 1e-3;

Eigen::Vector3d boundedVector(const YamlValue& value, double bound) {
  const Eigen::Vector3d v = value.vector3();
  if (!(v.cwiseAbs().maxCoeff() <= bound)) {
    value.fail("values must lie within +-" + std::to_string(bound));
  }
  return v;
}

// Joint maps ({joint name: degrees}) and limit checks against the model.
class JointReader {
 public:
  explicit JointReader(const HandModel& model) : model_(model) {
    const std::vector<std::string> names = model.parameterNames();
    for (int j = 0; j < kNumJointDof; ++j) joint_index_[names.at(kFirstJointDof + j)] = j;
  }

  // Joint angles in degrees -> (index, radians).
  std::map<int, double> joints(const YamlValue& map) const {
    std::map<int, double> out;
    if (!map.isMap()) map.fail("must be a map of joint names to degrees");
    for (const auto& [name, value] : map.entries()) {
      const auto it = joint_index_.find(name);
      if (it == joint_index_.end()) {
        std::string list;
        for (int j = 0; j < kNumJointDof; ++j) {
          list += (j ? ", " : "") + model_.parameterNames()[kFirstJointDof + j];
        }
        value.fail("unknown joint '" + name + "' (the model's joints are: " + list + ")");
      }
      out[it->second] = value.number() * kDeg;
    }
    return out;
  }

  void checkLimits(const JointVector& q, const YamlValue& where, const std::string& what) const {
    for (int j = 0; j < kNumJointDof; ++j) {
      const JointDof& dof = model_.joints[j];
      if (q[j] < dof.min - kLimitTolerance || q[j] > dof.max + kLimitTolerance) {
        std::ostringstream msg;
        msg << what << ": joint " << model_.parameterNames()[kFirstJointDof + j] << " = "
            << q[j] / kDeg << " deg is outside its limits [" << dof.min / kDeg << ", "
            << dof.max / kDeg << "] deg";
        where.fail(msg.str());
      }
    }
  }

 private:
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

// Only the keyframes around `time` matter: the segment [i, i+1] holding it and, for the PCHIP
// tangents, one neighbour on each side. Interpolating over that window (which keeps the ends of
// the motion as its ends) gives the same values as over all keyframes, in O(log n) instead of
// O(n) per call (a motion may have 10 000 keyframes and is sampled at every frame).
Eigen::Matrix<double, kChannels, 1> interpolate(const std::vector<MotionKeyframe>& keys, bool cubic,
                                                double time) {
  const auto after =
      std::upper_bound(keys.begin(), keys.end(), time,
                       [](double x, const MotionKeyframe& key) { return x < key.time; });
  const std::size_t segment = after == keys.begin() ? 0 : (after - keys.begin()) - 1;
  const std::size_t first = segment == 0 ? 0 : segment - 1;
  const std::size_t last = std::min(keys.size() - 1, segment + 2);
  const std::size_t count = last - first + 1;
  std::vector<double> t(count), y(count);
  std::vector<Eigen::Matrix<double, kChannels, 1>> values(count);
  for (std::size_t k = 0; k < count; ++k) {
    t[k] = keys[first + k].time;
    values[k] = channels(keys[first + k]);
  }
  Eigen::Matrix<double, kChannels, 1> out;
  for (int c = 0; c < kChannels; ++c) {
    for (std::size_t k = 0; k < count; ++k) y[k] = values[k][c];
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

namespace {

// True when a time in `times` lies less than `distance` from `t`. The nearest time on either
// side decides (|b - t| only grows away from t), so this is a look-up, not a scan: up to 10 000
// random keyframes are checked against each other.
bool hasTimeNear(const std::multiset<double>& times, double t, double distance) {
  const auto above = times.lower_bound(t);
  if (above != times.end() && std::abs(*above - t) < distance) return true;
  return above != times.begin() && std::abs(*std::prev(above) - t) < distance;
}

// Random keyframes (`random: keyframes:`), drawn around the explicit motion `base`.
void drawRandomKeyframes(const YamlValue& blocks, const HandModel& model, Motion* motion,
                         std::mt19937_64* rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  // One block (a map) or several (a list of maps), each over its own time span.
  std::vector<YamlValue> gens;
  if (blocks.isSequence()) {
    const std::size_t count = blocks.size(kMaxMotionKeyframes);
    for (std::size_t i = 0; i < count; ++i) gens.push_back(blocks[i]);
  } else {
    gens.push_back(blocks);
  }
  const std::vector<MotionKeyframe> base = motion->keyframes;
  std::multiset<double> base_times, drawn_times;
  for (const MotionKeyframe& key : base) base_times.insert(key.time);
  std::vector<MotionKeyframe> drawn;
  for (const YamlValue& gen : gens) {
    gen.allowOnly({"from", "to", "interval", "position", "orientation", "joints"});
    const double from = gen["from"].number(0.0, kMaxMotionSeconds);
    const double to = gen["to"].number(from, kMaxMotionSeconds);
    // Keyframes drawn after the motion's end were silently never shown (a typo in a time).
    if (to > motion->duration + 1e-9) {
      gen["to"].fail(shortNumber(to) + " s is after the motion's end at " +
                     shortNumber(motion->duration) +
                     " s (its duration, or its last keyframe's time): the random keyframes after "
                     "it would never be shown");
    }
    const YamlValue interval_node = gen["interval"];
    const double interval = interval_node.number();
    if (!(interval > 0.0)) interval_node.fail("must be positive");
    if (interval < kMinKeyframeSpacing) interval_node.fail("must be at least 1 ms");
    // Counted before anything is drawn: an interval of 1e-9 must not try 1e10 keyframes.
    const double wanted = std::floor((to - from) / interval + 1e-9) + 1.0;
    if (wanted + base.size() + drawn.size() > kMaxMotionKeyframes) {
      interval_node.fail("gives " + std::to_string(wanted) + " keyframes, more than the limit of " +
                         std::to_string(kMaxMotionKeyframes) + " for a motion");
    }
    const int count = static_cast<int>(wanted);
    const Eigen::Vector3d dp = gen.has("position")
                                   ? boundedVector(gen["position"], kMaxPositionMetres)
                                   : Eigen::Vector3d::Zero().eval();
    const Eigen::Vector3d dr = gen.has("orientation")
                                   ? boundedVector(gen["orientation"], kMaxAngleDegrees)
                                   : Eigen::Vector3d::Zero().eval();
    const double fraction = gen.has("joints") ? gen["joints"].number(0.0, 1.0) : 0.0;
    for (int i = 0; i < count; ++i) {
      const double t = from + i * interval;
      const bool near_other =
          hasTimeNear(base_times, t, 0.5 * interval) || hasTimeNear(drawn_times, t, 0.5 * interval);
      // Draw even when skipping, so that the draws do not depend on the skips.
      MotionKeyframe key;
      key.time = t;
      key.random = true;
      const Eigen::Matrix<double, kChannels, 1> centre = interpolate(base, motion->cubic, t);
      for (int a = 0; a < 3; ++a) key.position[a] = centre[a] + dp[a] * unit(*rng);
      for (int a = 0; a < 3; ++a) key.orientation[a] = centre[3 + a] + dr[a] * unit(*rng);
      for (int j = 0; j < kNumJointDof; ++j) {
        const double lo = model.joints[j].min, hi = model.joints[j].max;
        const double mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo) * fraction;
        key.joints[j] = fraction > 0.0 ? mid + half * unit(*rng) : centre[6 + j];
      }
      if (!near_other) {
        drawn.push_back(key);
        drawn_times.insert(t);
      }
    }
  }
  motion->keyframes.insert(motion->keyframes.end(), drawn.begin(), drawn.end());
  std::sort(motion->keyframes.begin(), motion->keyframes.end(),
            [](const MotionKeyframe& a, const MotionKeyframe& b) { return a.time < b.time; });
}

void readJitter(const YamlValue& jitter, Motion* motion, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  jitter.allowOnly({"position", "orientation", "joints", "frequency"});
  const double ap = jitter.has("position") ? jitter["position"].number(0.0, 1.0) : 0.0;
  const double ao = jitter.has("orientation") ? jitter["orientation"].number(0.0, 360.0) : 0.0;
  const double aj = jitter.has("joints") ? jitter["joints"].number(0.0, 360.0) * kDeg : 0.0;
  const double f = jitter.has("frequency") ? jitter["frequency"].number() : 1.0;
  if (!(f > 0.0) || f > 1000.0) jitter.get("frequency").fail("must be in (0, 1000] Hz");
  motion->jitter.channels.resize(kChannels);
  for (int c = 0; c < kChannels; ++c) {
    const double amplitude = c < 3 ? ap : (c < 6 ? ao : aj);
    for (int w = 0; w < 3; ++w) {
      MotionJitter::Wave wave;
      wave.amplitude = 0.5 * amplitude;
      wave.frequency = f * (1.0 + 0.5 * unit(*rng));
      wave.phase = M_PI * (1.0 + unit(*rng));
      motion->jitter.channels[c].push_back(wave);
    }
  }
}

Motion readMotion(const YamlDocument& document, const HandModel& model, std::uint64_t seed) {
  const YamlValue root = document.root();
  root.allowOnly({"name", "description", "duration", "interpolation", "shapes", "keyframes",
                  "random", "forearm"});
  const JointReader reader(model);
  Motion motion;
  motion.source = document.source();
  motion.name = root.textOr("name", baseName(document.source()));
  motion.description = root.textOr("description", "");
  for (int j = 0; j < kNumJointDof; ++j) {
    motion.joint_min[j] = model.joints[j].min;
    motion.joint_max[j] = model.joints[j].max;
  }
  if (root.has("interpolation")) {
    const YamlValue mode = root["interpolation"];
    if (mode.text() != "cubic" && mode.text() != "linear") {
      mode.fail("must be 'cubic' or 'linear', not '" + mode.text() + "'");
    }
    motion.cubic = mode.text() == "cubic";
  }
  if (root.has("forearm")) {
    const YamlValue forearm = root["forearm"];
    forearm.allowOnly({"bare", "bend"});
    if (forearm.has("bare")) {
      const YamlValue bare = forearm["bare"];
      if (bare.text() != "true" && bare.text() != "false") bare.fail("must be true or false");
      motion.bare_forearm = bare.text() == "true";
    }
    if (forearm.has("bend")) motion.forearm_bend = forearm["bend"].number(0.0, 10.0);
  }

  std::map<std::string, std::map<int, double>> shapes;
  if (root.has("shapes")) {
    for (const auto& [name, joints] : root["shapes"].entries())
      shapes[name] = reader.joints(joints);
  }

  const YamlValue keys = root["keyframes"];
  const std::size_t key_count = keys.size(kMaxMotionKeyframes);
  if (key_count == 0) keys.fail("must be a non-empty list");
  JointVector current;
  for (int j = 0; j < kNumJointDof; ++j) {
    current[j] = std::clamp(0.0, model.joints[j].min, model.joints[j].max);
  }
  int last_time_line = 0;  // of the last keyframe's time, for the duration's error
  for (std::size_t k = 0; k < key_count; ++k) {
    const YamlValue node = keys[k];
    node.allowOnly({"time", "position", "orientation", "shape", "joints"});
    MotionKeyframe key;
    const YamlValue time = node["time"];
    last_time_line = time.line();
    key.time = time.number(0.0, kMaxMotionSeconds);
    if (k > 0 && key.time < motion.keyframes.back().time + kMinKeyframeSpacing) {
      time.fail("times must increase strictly, by at least 1 ms (" + std::to_string(key.time) +
                " s follows " + std::to_string(motion.keyframes.back().time) + " s)");
    }
    key.position = k == 0
                       ? boundedVector(node["position"], kMaxPositionMetres)
                       : (node.has("position") ? boundedVector(node["position"], kMaxPositionMetres)
                                               : motion.keyframes.back().position);
    key.orientation = node.has("orientation") ? boundedVector(node["orientation"], kMaxAngleDegrees)
                                              : (k == 0 ? Eigen::Vector3d::Zero().eval()
                                                        : motion.keyframes.back().orientation);
    if (node.has("shape")) {
      const YamlValue shape = node["shape"];
      const auto it = shapes.find(shape.text());
      if (it == shapes.end()) shape.fail("unknown shape '" + shape.text() + "'");
      for (const auto& [j, value] : it->second) current[j] = value;
    }
    if (node.has("joints")) {
      for (const auto& [j, value] : reader.joints(node["joints"])) current[j] = value;
    }
    reader.checkLimits(
        current, node,
        "keyframe " + std::to_string(k + 1) + " (t = " + std::to_string(key.time) + " s)");
    key.joints = current;
    motion.keyframes.push_back(key);
  }
  motion.duration = motion.keyframes.back().time;
  if (root.has("duration")) {
    const YamlValue duration = root["duration"];
    motion.duration = duration.number();
    if (!(motion.duration > 0.0)) duration.fail("must be positive");
    if (motion.duration > kMaxMotionSeconds) {
      duration.fail("exceeds the limit of " + std::to_string(kMaxMotionSeconds) + " s");
    }
    // The keyframes after the end were silently never shown (a typo in either number).
    const double last_time = motion.keyframes.back().time;
    if (motion.duration < last_time) {
      duration.fail(shortNumber(motion.duration) + " s ends before the last keyframe's time " +
                    shortNumber(last_time) + " s (keyframes[" + std::to_string(key_count - 1) +
                    "], line " + std::to_string(last_time_line) +
                    "); the duration must be at least the last keyframe's time");
    }
  }
  if (motion.duration <= 0.0) {
    root.fail("duration is zero: give 'duration' or keyframes that span some time");
  }

  std::mt19937_64 rng(mixSeed(seed, nameHash(motion.name)));
  if (root.has("random")) {
    const YamlValue random = root["random"];
    random.allowOnly({"keyframes", "jitter"});
    if (random.has("keyframes")) drawRandomKeyframes(random["keyframes"], model, &motion, &rng);
    if (random.has("jitter")) readJitter(random["jitter"], &motion, &rng);
  }
  return motion;
}

}  // namespace

Motion parseMotion(const std::string& yaml_text, const std::string& source, const HandModel& model,
                   std::uint64_t seed) {
  if (static_cast<int>(model.joints.size()) != kNumJointDof) {
    throw InputError("motion " + source + ": the hand model has " +
                     std::to_string(model.joints.size()) + " joints, expected " +
                     std::to_string(kNumJointDof));
  }
  return readMotion(YamlDocument(yaml_text, source, "motion"), model, seed);
}

Motion loadMotion(const std::string& path, const HandModel& model, std::uint64_t seed) {
  return parseMotion(readYamlFileText(path, "motion"), path, model, seed);
}

const std::vector<std::string>& builtinMotionNames() {
  static const std::vector<std::string> names{"adbadd", "fingercount", "fingerwave", "flexex1",
                                              "pinch",  "random",      "tigergrasp"};
  return names;
}

const std::vector<std::string>& hardMotionNames() {
  static const std::vector<std::string> names{"raised", "pronation", "wristflex", "fastturn",
                                              "natural"};
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
  if (name_or_path.find('/') == std::string::npos && name_or_path.find('.') == std::string::npos &&
      std::ifstream(in_config).good()) {
    return in_config;
  }
  return name_or_path;
}

}  // namespace studio
}  // namespace sag_hand_tracker
