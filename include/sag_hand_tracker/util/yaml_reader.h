// The one YAML reader of the core (hand models, camera rigs and calibrations, studio motions).
// Every error it throws names the input, the line and the key:
//
//   hand model config/hand.yaml:42: key 'bones[3].dofs[1].axis': must be x, y or z, not 'w'
//
// A YamlValue is a node together with its document and its key path, so the parsers read values
// without repeating where they are.
#pragma once

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <cstddef>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "sag_hand_tracker/util/input_limits.h"

namespace sag_hand_tracker {

class YamlValue;

// Parses the (first) document of `text`: the one place every YAML input of the core is parsed.
// Throws InputError "<kind> <source>:<line>: key '<map>': ..." when the text exceeds
// kMaxYamlFileBytes, is malformed YAML, nests maps and lists deeper than kMaxYamlNestingDepth
// (checked while parsing, so 100000 '[' cost no deep recursion) or repeats a key of a map
// ("duplicate key 'length' (first at line 55)": yaml-cpp would keep both and its look-ups use
// the first).
YAML::Node parseYamlText(const std::string& text, const std::string& source,
                         const std::string& kind);

// A parsed YAML document and what it is ("hand model", "motion", ...) and where it came from.
class YamlDocument {
 public:
  // Parses `text` (parseYamlText: size, malformed YAML, nesting and duplicate keys are errors).
  YamlDocument(const std::string& text, std::string source, std::string kind);
  // Reads and parses a file; a missing file, a directory, a file larger than `max_bytes` or an
  // unreadable one is an InputError naming it (the size is checked before reading).
  static YamlDocument fromFile(const std::string& path, const std::string& kind,
                               std::size_t max_bytes = kMaxYamlFileBytes);

  // The top level, which must be a map.
  YamlValue root() const;
  const std::string& source() const { return source_; }
  const std::string& kind() const { return kind_; }

  // "<kind> <source>:<line>: key '<key>': <problem>" (line and key left out when unknown).
  [[noreturn]] void fail(int line, const std::string& key, const std::string& problem) const;

 private:
  YAML::Node root_;
  std::string source_;
  std::string kind_;
};

// Reads the text of a file for a YAML reader: an InputError "<kind> <path>: ..." when it does
// not exist, is a directory, is larger than `max_bytes` (checked before reading) or cannot be read.
std::string readYamlFileText(const std::string& path, const std::string& kind,
                             std::size_t max_bytes = kMaxYamlFileBytes);

// `value` as a YAML scalar, quoted and escaped where plain text would not read back the same
// (yaml-cpp's emitter): how the model and rig writers put names and paths into their files.
std::string yamlString(const std::string& value);

class YamlValue {
 public:
  YamlValue(const YamlDocument* document, YAML::Node node, std::string key, int line);

  const std::string& key() const { return key_; }
  int line() const { return line_; }
  const YAML::Node& node() const { return node_; }
  bool isMap() const { return node_.IsMap(); }
  bool isSequence() const { return node_.IsSequence(); }
  [[noreturn]] void fail(const std::string& problem) const;

  // Map access. has(): present and not null. operator[]: required (else "missing"); get():
  // optional, check has() or use the *Or readers.
  bool has(const std::string& key) const;
  YamlValue operator[](const std::string& key) const;
  YamlValue get(const std::string& key) const;
  // Refuses keys outside `allowed` (typos must not be ignored silently).
  void allowOnly(const std::vector<std::string>& allowed) const;
  // The entries of a map in file order (key text, value).
  std::vector<std::pair<std::string, YamlValue>> entries() const;

  // Sequence access; size() fails unless this is a list, and at most `max_size` entries.
  std::size_t size(std::size_t max_size = static_cast<std::size_t>(-1)) const;
  YamlValue operator[](std::size_t index) const;

  // Scalars. number() is finite; integer() is an int; text() any scalar.
  double number() const;
  double number(double min, double max) const;  // within [min, max]
  int integer() const;
  std::string text() const;
  // A list of numbers, of exactly `size` entries when size >= 0.
  std::vector<double> numbers(int size = -1) const;
  Eigen::Vector3d vector3() const;

  // Optional members with a default.
  double numberOr(const std::string& key, double fallback) const;
  std::string textOr(const std::string& key, const std::string& fallback) const;
  Eigen::Vector3d vector3Or(const std::string& key, const Eigen::Vector3d& fallback) const;

 private:
  const YamlDocument* document_;
  YAML::Node node_;
  std::string key_;
  int line_;  // 1-based, 0 when unknown
};

}  // namespace sag_hand_tracker
