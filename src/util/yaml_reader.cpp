#include "sag_hand_tracker/util/yaml_reader.h"

#include <yaml-cpp/eventhandler.h>

#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <set>
#include <sstream>
#include <unordered_map>
#include <vector>

#include "sag_hand_tracker/util/number_text.h"
#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

namespace fs = std::filesystem;

int lineOf(const YAML::Node& node, int fallback) {
  if (!node.IsDefined()) return fallback;
  const YAML::Mark mark = node.Mark();
  return mark.is_null() || mark.line < 0 ? fallback : mark.line + 1;
}

// "<kind> <source>:<line>: key '<key>': <problem>" (line and key left out when unknown).
std::string yamlMessage(const std::string& kind, const std::string& source, int line,
                        const std::string& key, const std::string& problem) {
  std::ostringstream message;
  message << kind << " " << source;
  if (line > 0) message << ":" << line;
  message << ": ";
  if (!key.empty()) message << "key '" << key << "': ";
  message << problem;
  return message.str();
}

// Follows the parser's events before a document is built from them, for what the built document
// no longer shows or costs too much to reach: the nesting depth (refused as soon as it passes the
// limit, while yaml-cpp's recursion is that deep) and keys repeated in a map.
class StructureCheck : public YAML::EventHandler {
 public:
  StructureCheck(const std::string& source, const std::string& kind)
      : source_(source), kind_(kind) {}

  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark& mark, YAML::anchor_t) override { node(mark, nullptr); }
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { node(mark, nullptr); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                const std::string& value) override {
    node(mark, &value);
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {
    open(mark, false);
  }
  void OnSequenceEnd() override { stack_.pop_back(); }
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                  YAML::EmitterStyle::value) override {
    open(mark, true);
  }
  void OnMapEnd() override { stack_.pop_back(); }

 private:
  struct Collection {
    bool map = false;
    std::string path;                           // its key path, as YamlValue names it
    std::size_t nodes = 0;                      // nodes in it so far (a map's: key, value, ...)
    std::string key;                            // a map's: the key of the value that comes next
    std::unordered_map<std::string, int> keys;  // a map's keys so far and their lines
  };

  static int lineOf(const YAML::Mark& mark) { return mark.is_null() ? 0 : mark.line + 1; }

  [[noreturn]] void fail(int line, const std::string& key, const std::string& problem) const {
    throw InputError(yamlMessage(kind_, source_, line, key, problem));
  }

  // Any node; `scalar` is a scalar's text, else null. Returns the node's key path.
  std::string node(const YAML::Mark& mark, const std::string* scalar) {
    if (stack_.empty()) return "";
    Collection& parent = stack_.back();
    const std::size_t index = parent.nodes++;
    if (!parent.map) return parent.path + "[" + std::to_string(index) + "]";
    if (index % 2 == 1) return parent.path.empty() ? parent.key : parent.path + "." + parent.key;
    // A key: a plain one must be new to its map; a list or map as a key is no name (the readers
    // refuse it where they read the map).
    parent.key = scalar ? *scalar : "?";
    if (scalar) {
      const int line = lineOf(mark);
      const auto [first, fresh] = parent.keys.emplace(*scalar, line);
      if (!fresh) {
        fail(line, parent.path,
             "duplicate key '" + *scalar + "' (first at line " + std::to_string(first->second) +
                 ")");
      }
    }
    return parent.path;
  }

  void open(const YAML::Mark& mark, bool map) {
    std::string path = node(mark, nullptr);
    if (stack_.size() >= static_cast<std::size_t>(kMaxYamlNestingDepth)) {
      fail(lineOf(mark), path,
           "maps and lists nested deeper than the limit of " +
               std::to_string(kMaxYamlNestingDepth) + " levels");
    }
    stack_.push_back(Collection{map, std::move(path), 0, "", {}});
  }

  const std::string& source_;
  const std::string& kind_;
  std::vector<Collection> stack_;
};

// What has() asks of a member, on the member itself (no second look-up).
bool isPresent(const YAML::Node& node) { return node.IsDefined() && !node.IsNull(); }

// The member `key` of a map holding it, else nullopt: one look-up where has() + get() take two
// (yaml-cpp searches a map linearly).
std::optional<YamlValue> presentMember(const YamlValue& map, const std::string& key) {
  if (!map.isMap()) return std::nullopt;
  YamlValue child = map.get(key);
  if (!isPresent(child.node())) return std::nullopt;
  return child;
}

}  // namespace

std::string yamlString(const std::string& value) {
  YAML::Emitter out;
  out << value;
  return out.c_str();
}

std::string readYamlFileText(const std::string& path, const std::string& kind,
                             std::size_t max_bytes) {
  std::error_code error;
  const fs::file_status status = fs::status(path, error);
  if (!fs::exists(status)) throw InputError(kind + " " + path + ": does not exist");
  if (fs::is_directory(status))
    throw InputError(kind + " " + path + ": is a directory, not a file");
  if (!fs::is_regular_file(status)) throw InputError(kind + " " + path + ": is not a regular file");
  const std::uintmax_t size = fs::file_size(path, error);
  if (error) throw InputError(kind + " " + path + ": cannot read: " + error.message());
  if (size > max_bytes) {
    throw InputError(kind + " " + path + ": " + std::to_string(size) +
                     " bytes, larger than the limit of " + std::to_string(max_bytes) + " bytes");
  }
  std::ifstream file(path, std::ios::binary);
  if (!file) throw InputError(kind + " " + path + ": cannot open the file");
  std::ostringstream text;
  text << file.rdbuf();
  if (file.bad()) throw InputError(kind + " " + path + ": error while reading the file");
  return text.str();
}

YAML::Node parseYamlText(const std::string& text, const std::string& source,
                         const std::string& kind) {
  if (text.size() > kMaxYamlFileBytes) {
    throw InputError(yamlMessage(kind, source, 0, "",
                                 std::to_string(text.size()) + " bytes, larger than the limit of " +
                                     std::to_string(kMaxYamlFileBytes) + " bytes"));
  }
  try {
    // The events first (depth, duplicate keys), then the document from a second parse of the
    // checked text: yaml-cpp builds documents only in YAML::Load.
    std::istringstream stream(text);
    YAML::Parser parser(stream);
    StructureCheck check(source, kind);
    parser.HandleNextDocument(check);
    return YAML::Load(text);
  } catch (const YAML::Exception& error) {
    throw InputError(yamlMessage(kind, source, error.mark.is_null() ? 0 : error.mark.line + 1, "",
                                 "malformed YAML: " + error.msg));
  }
}

YamlDocument::YamlDocument(const std::string& text, std::string source, std::string kind)
    : source_(std::move(source)), kind_(std::move(kind)) {
  root_ = parseYamlText(text, source_, kind_);
}

YamlDocument YamlDocument::fromFile(const std::string& path, const std::string& kind,
                                    std::size_t max_bytes) {
  return YamlDocument(readYamlFileText(path, kind, max_bytes), path, kind);
}

YamlValue YamlDocument::root() const {
  YamlValue root(this, root_, "", lineOf(root_, 0));
  if (!root_.IsMap()) root.fail("the document must be a YAML map");
  return root;
}

void YamlDocument::fail(int line, const std::string& key, const std::string& problem) const {
  throw InputError(yamlMessage(kind_, source_, line, key, problem));
}

YamlValue::YamlValue(const YamlDocument* document, YAML::Node node, std::string key, int line)
    : document_(document), node_(std::move(node)), key_(std::move(key)), line_(line) {}

void YamlValue::fail(const std::string& problem) const { document_->fail(line_, key_, problem); }

bool YamlValue::has(const std::string& key) const {
  if (!node_.IsMap()) return false;
  const YAML::Node child = node_[key];
  return child.IsDefined() && !child.IsNull();
}

YamlValue YamlValue::get(const std::string& key) const {
  if (!node_.IsMap()) fail("must be a map");
  const YAML::Node child = node_[key];
  const std::string path = key_.empty() ? key : key_ + "." + key;
  return YamlValue(document_, child, path, lineOf(child, line_));
}

YamlValue YamlValue::operator[](const std::string& key) const {
  YamlValue child = get(key);
  if (!isPresent(child.node())) child.fail("missing");
  return child;
}

void YamlValue::allowOnly(const std::vector<std::string>& allowed) const {
  if (!node_.IsMap()) fail("must be a map");
  const std::set<std::string> known(allowed.begin(), allowed.end());
  for (const auto& item : node_) {
    const std::string name = item.first.IsScalar() ? item.first.Scalar() : "?";
    if (!known.count(name)) {
      std::string list;
      for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
      YamlValue(document_, item.first, key_.empty() ? name : key_ + "." + name,
                lineOf(item.first, line_))
          .fail("unknown key (expected one of: " + list + ")");
    }
  }
}

std::vector<std::pair<std::string, YamlValue>> YamlValue::entries() const {
  if (!node_.IsMap()) fail("must be a map");
  std::vector<std::pair<std::string, YamlValue>> result;
  for (const auto& item : node_) {
    if (!item.first.IsScalar()) {
      YamlValue(document_, item.first, key_, lineOf(item.first, line_))
          .fail("map keys must be plain names");
    }
    const std::string name = item.first.Scalar();
    result.emplace_back(name,
                        YamlValue(document_, item.second, key_.empty() ? name : key_ + "." + name,
                                  lineOf(item.second, line_)));
  }
  return result;
}

std::size_t YamlValue::size(std::size_t max_size) const {
  if (!node_.IsSequence()) fail("must be a list");
  const std::size_t count = node_.size();
  if (count > max_size) {
    fail("has " + std::to_string(count) + " entries, more than the limit of " +
         std::to_string(max_size));
  }
  return count;
}

YamlValue YamlValue::operator[](std::size_t index) const {
  if (!node_.IsSequence()) fail("must be a list");
  const YAML::Node child = node_[index];
  return YamlValue(document_, child, key_ + "[" + std::to_string(index) + "]",
                   lineOf(child, line_));
}

double YamlValue::number() const {
  if (!node_.IsScalar()) fail("must be a number");
  double value = 0.0;
  try {
    value = node_.as<double>();
  } catch (const YAML::Exception&) {
    fail("must be a number, not '" + node_.Scalar() + "'");
  }
  if (!std::isfinite(value)) fail("must be finite, not '" + node_.Scalar() + "'");
  return value;
}

double YamlValue::number(double min, double max) const {
  const double value = number();
  if (value < min || value > max) {
    fail(shortNumber(value) + " is outside [" + shortNumber(min) + ", " + shortNumber(max) + "]");
  }
  return value;
}

int YamlValue::integer() const {
  if (!node_.IsScalar()) fail("must be an integer");
  try {
    return node_.as<int>();
  } catch (const YAML::Exception&) {
    fail("must be an integer, not '" + node_.Scalar() + "'");
  }
}

std::string YamlValue::text() const {
  if (!node_.IsScalar()) fail("must be a text (a YAML scalar)");
  return node_.Scalar();
}

std::vector<double> YamlValue::numbers(int expected) const {
  if (!node_.IsSequence()) fail("must be a list of numbers");
  const std::size_t count = node_.size();
  if (expected >= 0 && count != static_cast<std::size_t>(expected)) {
    fail("must be a list of " + std::to_string(expected) + " numbers, not " +
         std::to_string(count));
  }
  std::vector<double> values;
  values.reserve(count);
  for (std::size_t i = 0; i < count; ++i) values.push_back((*this)[i].number());
  return values;
}

Eigen::Vector3d YamlValue::vector3() const {
  const std::vector<double> v = numbers(3);
  return Eigen::Vector3d(v[0], v[1], v[2]);
}

double YamlValue::numberOr(const std::string& key, double fallback) const {
  const std::optional<YamlValue> child = presentMember(*this, key);
  return child ? child->number() : fallback;
}

std::string YamlValue::textOr(const std::string& key, const std::string& fallback) const {
  const std::optional<YamlValue> child = presentMember(*this, key);
  return child ? child->text() : fallback;
}

Eigen::Vector3d YamlValue::vector3Or(const std::string& key,
                                     const Eigen::Vector3d& fallback) const {
  const std::optional<YamlValue> child = presentMember(*this, key);
  return child ? child->vector3() : fallback;
}

}  // namespace sag_hand_tracker
