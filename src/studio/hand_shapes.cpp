#include "sag_hand_tracker/studio/hand_shapes.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>

#include "sag_hand_tracker/util/types.h"
#include "sag_hand_tracker/util/yaml_reader.h"

namespace sag_hand_tracker {
namespace studio {

namespace {

class ShapeParser {
 public:
  explicit ShapeParser(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const YAML::Node& node, const std::string& problem) const {
    std::ostringstream msg;
    msg << "hand shapes " << source_;
    if (node.IsDefined() && node.Mark().line >= 0) msg << ":" << node.Mark().line + 1;
    msg << ": " << problem;
    throw InputError(msg.str());
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

  // A size factor: positive, and within a sane range so that a typo (15 for 1.5) is caught.
  double factor(const YAML::Node& node, const std::string& what) const {
    const double value = number(node, what);
    if (!(value >= 0.3 && value <= 3.0)) {
      std::ostringstream msg;
      msg << what << " = " << value << " is outside [0.3, 3] (a factor on the model's size)";
      fail(node, msg.str());
    }
    return value;
  }

  std::vector<double> factors(const YAML::Node& node, size_t count, const std::string& what) const {
    if (node.IsScalar()) return std::vector<double>(count, factor(node, what));
    if (!node.IsSequence() || node.size() != count) {
      fail(node, what + " must be one number or a list of " + std::to_string(count));
    }
    std::vector<double> out;
    for (size_t i = 0; i < count; ++i) out.push_back(factor(node[i], what));
    return out;
  }

  // A number within [-limit, limit] `unit`s (the skeleton's layout: millimetres, degrees).
  double bounded(const YAML::Node& node, double limit, const std::string& unit,
                 const std::string& what) const {
    const double value = number(node, what);
    if (std::abs(value) > limit) {
      std::ostringstream msg;
      msg << what << " = " << value << " " << unit << " is outside [-" << limit << ", " << limit
          << "]";
      fail(node, msg.str());
    }
    return value;
  }

  // Per finger a list of 3 bounded numbers, as a map {thumb: [..], index: [..], ...}; the fingers
  // left out keep zero. `scale` converts to the model's units.
  void perFingerVectors(const YAML::Node& node, double limit, const std::string& unit, double scale,
                        const std::string& what,
                        std::array<Eigen::Vector3d, kNumFingers>& out) const {
    std::set<std::string> fingers(fingerNames().begin(), fingerNames().end());
    checkKeys(node, fingers, what);
    for (int f = 0; f < kNumFingers; ++f) {
      const YAML::Node v = node[fingerNames()[f]];
      if (!v) continue;
      const std::string name = what + " " + fingerNames()[f];
      if (!v.IsSequence() || v.size() != 3) fail(v, name + " must be a list of 3 numbers");
      for (int i = 0; i < 3; ++i) out[f][i] = scale * bounded(v[i], limit, unit, name);
    }
  }

  Eigen::Vector3f colour(const YAML::Node& node, const std::string& what) const {
    if (!node.IsSequence() || node.size() != 3) {
      fail(node, what + " must be a list of 3 numbers (linear RGB in [0, 1])");
    }
    Eigen::Vector3f c;
    for (int i = 0; i < 3; ++i) {
      const double v = number(node[i], what);
      if (v < 0.0 || v > 1.0) fail(node[i], what + " values must lie in [0, 1]");
      c[i] = static_cast<float>(v);
    }
    return c;
  }

  StudioHand hand(const YAML::Node& node, const std::string& where) const {
    checkKeys(node,
              {"name", "description", "scale", "finger_length", "phalanx_length", "palm_width",
               "palm_length", "thickness", "knuckle_shift_mm", "base_rotation_deg",
               "flexion_tilt_deg", "skin"},
              where);
    StudioHand hand;
    if (!node["name"]) fail(node, where + ": 'name' is missing");
    hand.name = node["name"].as<std::string>();
    if (hand.name.empty()) fail(node["name"], where + ": the name is empty");
    for (char c : hand.name) {
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') {
        fail(node["name"], where + ": name '" + hand.name +
                               "' may hold only letters, digits and '_' (it names files)");
      }
    }
    if (drawnHandSeed(hand.name) >= 0) {
      fail(node["name"], where + ": name '" + hand.name +
                             "' is reserved for the hands drawn at random (drawn<N>)");
    }
    const std::string what = "shape '" + hand.name + "'";
    if (node["description"]) hand.description = node["description"].as<std::string>();
    HandShape& shape = hand.shape;
    if (node["scale"]) shape.scale = factor(node["scale"], what + " scale");
    if (node["palm_width"]) shape.palm_width = factor(node["palm_width"], what + " palm_width");
    if (node["palm_length"]) shape.palm_length = factor(node["palm_length"], what + " palm_length");
    if (node["thickness"]) shape.thickness = factor(node["thickness"], what + " thickness");
    if (node["finger_length"]) {
      const auto f = factors(node["finger_length"], kNumFingers, what + " finger_length");
      for (int i = 0; i < kNumFingers; ++i) shape.finger_length[i] = f[i];
    }
    if (const YAML::Node phalanx = node["phalanx_length"]) {
      if (phalanx.IsMap()) {
        std::set<std::string> fingers(fingerNames().begin(), fingerNames().end());
        checkKeys(phalanx, fingers, what + " phalanx_length");
        for (int f = 0; f < kNumFingers; ++f) {
          if (!phalanx[fingerNames()[f]]) continue;
          const auto p =
              factors(phalanx[fingerNames()[f]], 3, what + " phalanx_length " + fingerNames()[f]);
          for (int k = 0; k < 3; ++k) shape.phalanx_length[f][k] = p[k];
        }
      } else {
        const auto p = factors(phalanx, 3, what + " phalanx_length");
        for (int f = 0; f < kNumFingers; ++f) {
          for (int k = 0; k < 3; ++k) shape.phalanx_length[f][k] = p[k];
        }
      }
    }
    if (const YAML::Node shift = node["knuckle_shift_mm"]) {
      perFingerVectors(shift, kMaxKnuckleShiftMm, "mm", 1e-3, what + " knuckle_shift_mm",
                       shape.knuckle_shift);
    }
    if (const YAML::Node rotation = node["base_rotation_deg"]) {
      perFingerVectors(rotation, kMaxBaseRotationDeg, "deg", M_PI / 180.0,
                       what + " base_rotation_deg", shape.base_rotation);
    }
    if (const YAML::Node tilt = node["flexion_tilt_deg"]) {
      const std::string name = what + " flexion_tilt_deg";
      if (!tilt.IsSequence() || tilt.size() != kNumFingers) {
        fail(tilt, name + " must be a list of 5 numbers (thumb..pinky)");
      }
      for (int f = 0; f < kNumFingers; ++f) {
        shape.flexion_tilt[f] = M_PI / 180.0 * bounded(tilt[f], kMaxFlexionTiltDeg, "deg", name);
      }
    }
    if (const YAML::Node skin = node["skin"]) {
      checkKeys(skin, {"dorsal", "palmar", "nail"}, what + " skin");
      if (skin["dorsal"]) hand.skin.dorsal = colour(skin["dorsal"], what + " skin dorsal");
      if (skin["palmar"]) hand.skin.palmar = colour(skin["palmar"], what + " skin palmar");
      if (skin["nail"]) hand.skin.nail = colour(skin["nail"], what + " skin nail");
    }
    return hand;
  }

 private:
  std::string source_;
};

// Uniform in [lo, hi) from the generator's raw 64 bits (std::uniform_real_distribution is not
// the same on every standard library; the drawn hands must be).
double uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

bool looksLikeFile(const std::string& text) {
  return text.find('/') != std::string::npos || text.find('.') != std::string::npos;
}

}  // namespace

std::vector<StudioHand> parseHandShapes(const std::string& yaml_text, const std::string& source) {
  const ShapeParser parser(source);
  // The core's YAML parse (yaml_reader.h): size, nesting and duplicate keys are checked there.
  const YAML::Node root = parseYamlText(yaml_text, source, "hand shapes");
  if (!root.IsMap()) parser.fail(root, "the document must be a map with a 'shapes' list");
  parser.checkKeys(root, {"shapes"}, "the document");
  const YAML::Node list = root["shapes"];
  if (!list || !list.IsSequence() || list.size() == 0) {
    parser.fail(list ? list : root, "'shapes' must be a non-empty list");
  }
  std::vector<StudioHand> hands;
  std::set<std::string> names;
  for (size_t i = 0; i < list.size(); ++i) {
    hands.push_back(parser.hand(list[i], "shape " + std::to_string(i + 1)));
    if (!names.insert(hands.back().name).second) {
      parser.fail(list[i]["name"], "shape name '" + hands.back().name + "' appears twice");
    }
  }
  return hands;
}

std::vector<StudioHand> loadHandShapes(const std::string& path) {
  // Read as every YAML input is: a FIFO given as --shape hung the tool (open waits for a writer,
  // SIGTERM too), /dev/zero was read until memory ran out, a directory was an empty document.
  return parseHandShapes(readYamlFileText(path, "hand shapes"), path);
}

std::string handShapesPath(const std::string& config_dir) {
  return config_dir + "/hand_shapes.yaml";
}

std::vector<std::string> handShapeNames(const std::string& config_dir) {
  std::vector<std::string> names;
  for (const StudioHand& hand : loadHandShapes(handShapesPath(config_dir))) {
    names.push_back(hand.name);
  }
  return names;
}

std::string handShapeFile(const std::string& name_or_file, const std::string& config_dir) {
  return looksLikeFile(name_or_file) ? name_or_file : handShapesPath(config_dir);
}

int drawnHandSeed(const std::string& name) {
  static const std::string prefix = "drawn";
  if (name.size() <= prefix.size() || name.size() > prefix.size() + 7 ||
      name.compare(0, prefix.size(), prefix) != 0) {
    return -1;
  }
  const std::string digits = name.substr(prefix.size());
  if (digits.size() > 1 && digits[0] == '0') return -1;
  for (char c : digits) {
    if (!std::isdigit(static_cast<unsigned char>(c))) return -1;
  }
  const int seed = std::stoi(digits);
  return seed <= kMaxDrawnHandSeed ? seed : -1;
}

StudioHand drawHandShape(int seed, const std::vector<SkinAlbedo>& skin_tones) {
  if (seed < 0 || seed > kMaxDrawnHandSeed) {
    throw InputError("drawn hand seed " + std::to_string(seed) + " is outside 0.." +
                     std::to_string(kMaxDrawnHandSeed));
  }
  std::mt19937_64 rng(0x5A6D4A11u + 0x9E3779B97F4A7C15ull * static_cast<uint64_t>(seed));
  StudioHand hand;
  hand.name = "drawn" + std::to_string(seed);
  HandShape& shape = hand.shape;
  shape.scale = uniform(rng, 0.9, 1.1);
  for (double& length : shape.finger_length) length = uniform(rng, 0.95, 1.05);
  // Phalanx proportions: t = 0 the model's, 1 long_distal's (config/hand_shapes.yaml).
  const double t = uniform(rng, -0.3, 1.0);
  for (int f = 0; f < kNumFingers; ++f) {
    const bool thumb = f == 0;
    const std::array<double, 3> towards =
        thumb ? std::array<double, 3>{{0.0, -0.15, 0.35}} : std::array<double, 3>{{-0.2, 0.0, 0.5}};
    for (int k = 0; k < 3; ++k) {
      shape.phalanx_length[f][k] = (1.0 + t * towards[k]) * uniform(rng, 0.95, 1.05);
    }
  }
  shape.palm_width = uniform(rng, 0.9, 1.1);
  shape.palm_length = uniform(rng, 0.9, 1.1);
  shape.thickness = uniform(rng, 0.8, 1.2);
  std::ostringstream description;
  description.precision(2);
  description << std::fixed << "drawn with seed " << seed << ": size " << shape.scale
              << ", phalanx proportions t " << t << ", palm " << shape.palm_width << " wide and "
              << shape.palm_length << " long, thickness " << shape.thickness;
  if (!skin_tones.empty()) {
    const size_t a = rng() % skin_tones.size(), b = rng() % skin_tones.size();
    const float w = static_cast<float>(uniform(rng, 0.0, 1.0));
    const auto mix = [&](const Eigen::Vector3f SkinAlbedo::*albedo) {
      return ((1.0f - w) * (skin_tones[a].*albedo) + w * (skin_tones[b].*albedo)).eval();
    };
    hand.skin.dorsal = mix(&SkinAlbedo::dorsal);
    hand.skin.palmar = mix(&SkinAlbedo::palmar);
    hand.skin.nail = mix(&SkinAlbedo::nail);
    description << ", skin dorsal [" << hand.skin.dorsal.x() << ", " << hand.skin.dorsal.y() << ", "
                << hand.skin.dorsal.z() << "]";
  }
  hand.description = description.str();
  return hand;
}

std::vector<SkinAlbedo> configSkinTones(const std::string& config_dir) {
  std::vector<SkinAlbedo> tones;
  const std::string path = handShapesPath(config_dir);
  std::error_code error;
  if (!std::filesystem::exists(path, error)) return tones;
  for (const StudioHand& hand : loadHandShapes(path)) {
    const bool known = std::any_of(tones.begin(), tones.end(), [&](const SkinAlbedo& tone) {
      return tone.dorsal == hand.skin.dorsal && tone.palmar == hand.skin.palmar &&
             tone.nail == hand.skin.nail;
    });
    if (!known) tones.push_back(hand.skin);
  }
  return tones;
}

StudioHand resolveHandShape(const std::string& name_or_file, const std::string& config_dir) {
  if (const int seed = drawnHandSeed(name_or_file); seed >= 0) {
    return drawHandShape(seed, configSkinTones(config_dir));
  }
  if (looksLikeFile(name_or_file)) {
    const std::vector<StudioHand> hands = loadHandShapes(name_or_file);
    if (hands.size() != 1) {
      throw InputError("hand shapes " + name_or_file + ": holds " + std::to_string(hands.size()) +
                       " shapes; a shape file for --shape must hold exactly one");
    }
    return hands.front();
  }
  const std::string path = handShapesPath(config_dir);
  std::error_code error;
  if (name_or_file == "default" && !std::filesystem::exists(path, error)) return StudioHand();
  std::string known;
  for (const StudioHand& hand : loadHandShapes(path)) {
    if (hand.name == name_or_file) return hand;
    known += (known.empty() ? "" : ", ") + hand.name;
  }
  if (name_or_file == "default") return StudioHand();
  throw InputError("no hand shape '" + name_or_file + "' in " + path + " (known: " + known +
                   "; drawn<N> for a hand drawn at random with seed N; or give a shape file)");
}

}  // namespace studio
}  // namespace sag_hand_tracker
