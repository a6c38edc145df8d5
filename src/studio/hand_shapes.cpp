#include "sag_hand_tracker/studio/hand_shapes.h"

#include <yaml-cpp/yaml.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
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
               "palm_length", "thickness", "skin"},
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

StudioHand resolveHandShape(const std::string& name_or_file, const std::string& config_dir) {
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
                   "; or give a shape file)");
}

}  // namespace studio
}  // namespace sag_hand_tracker
