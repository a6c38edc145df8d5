#include "sag_hand_tracker/util/yaml_reader.h"

#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <set>
#include <sstream>

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {
namespace {

namespace fs = std::filesystem;

int lineOf(const YAML::Node& node, int fallback) {
  if (!node.IsDefined()) return fallback;
  const YAML::Mark mark = node.Mark();
  return mark.is_null() || mark.line < 0 ? fallback : mark.line + 1;
}

std::string shortNumber(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

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

YamlDocument::YamlDocument(const std::string& text, std::string source, std::string kind)
    : source_(std::move(source)), kind_(std::move(kind)) {
  if (text.size() > kMaxYamlFileBytes) {
    fail(0, "",
         std::to_string(text.size()) + " bytes, larger than the limit of " +
             std::to_string(kMaxYamlFileBytes) + " bytes");
  }
  try {
    root_ = YAML::Load(text);
  } catch (const YAML::Exception& error) {
    fail(error.mark.is_null() ? 0 : error.mark.line + 1, "", "malformed YAML: " + error.msg);
  }
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
  std::ostringstream message;
  message << kind_ << " " << source_;
  if (line > 0) message << ":" << line;
  message << ": ";
  if (!key.empty()) message << "key '" << key << "': ";
  message << problem;
  throw InputError(message.str());
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
