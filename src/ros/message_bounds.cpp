#include "sag_hand_tracker/ros/message_bounds.h"

#include <cstring>
#include <map>
#include <mutex>
#include <sstream>
#include <utility>

namespace sag_hand_tracker {
namespace {

struct Field {
  std::string type;  // builtin name, or "pkg/Type"
  std::string name;
  bool is_array = false;
  long fixed_length = -1;  // T[N]: N; T[]: -1
};

struct Definitions {
  std::string main;
  std::map<std::string, std::vector<Field>> types;
};

std::size_t builtinSize(const std::string& type) {
  static const std::map<std::string, std::size_t> sizes = {
      {"bool", 1},  {"int8", 1},   {"uint8", 1},   {"byte", 1},   {"char", 1},
      {"int16", 2}, {"uint16", 2}, {"int32", 4},   {"uint32", 4}, {"float32", 4},
      {"int64", 8}, {"uint64", 8}, {"float64", 8}, {"time", 8},   {"duration", 8}};
  const auto found = sizes.find(type);
  return found == sizes.end() ? 0 : found->second;
}

std::string trim(const std::string& text) {
  const std::size_t first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return text.substr(first, text.find_last_not_of(" \t\r") - first + 1);
}

std::string packageOf(const std::string& type) {
  const std::size_t slash = type.find('/');
  return slash == std::string::npos ? "" : type.substr(0, slash);
}

// Field types as written in a section of package `package`: "Header", a builtin, "Type" (same
// package) or "pkg/Type".
std::string resolveType(const std::string& type, const std::string& package) {
  if (type == "Header") return "std_msgs/Header";
  if (type == "string" || builtinSize(type) > 0 || type.find('/') != std::string::npos) return type;
  return package + "/" + type;
}

Definitions parseDefinitions(const std::string& datatype, const std::string& text) {
  Definitions definitions;
  definitions.main = datatype;
  std::string current = datatype, package = packageOf(datatype);
  definitions.types[current];
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    const std::size_t comment = line.find('#');
    if (comment != std::string::npos) line.erase(comment);
    line = trim(line);
    if (line.empty()) continue;
    if (line.rfind("====", 0) == 0) continue;
    if (line.rfind("MSG:", 0) == 0) {
      current = trim(line.substr(4));
      package = packageOf(current);
      definitions.types[current];
      continue;
    }
    std::istringstream words(line);
    std::string type, name;
    words >> type >> name;
    if (name.empty() || name.find('=') != std::string::npos ||
        line.find('=') != std::string::npos) {
      continue;  // a constant
    }
    Field field;
    field.name = name;
    const std::size_t bracket = type.find('[');
    if (bracket != std::string::npos) {
      field.is_array = true;
      const std::string length = type.substr(bracket + 1, type.find(']') - bracket - 1);
      field.fixed_length = length.empty() ? -1 : std::stol(length);
      type.erase(bracket);
    }
    field.type = resolveType(type, package);
    definitions.types[current].push_back(field);
  }
  return definitions;
}

class Walker {
 public:
  Walker(const Definitions& definitions, const std::uint8_t* data, std::size_t size)
      : definitions_(definitions), data_(data), size_(size) {}

  std::string run() {
    if (!walkType(definitions_.main, 0)) return problem_;
    if (offset_ != size_) {
      return std::to_string(size_ - offset_) + " bytes left over after the message";
    }
    return "";
  }

 private:
  std::size_t left() const { return size_ - offset_; }

  bool fail(const std::string& problem) {
    problem_ = problem;
    return false;
  }

  bool readLength(const std::string& field, std::uint32_t* length) {
    if (left() < 4) return fail(field + ": length prefix cut off");
    std::memcpy(length, data_ + offset_, 4);
    offset_ += 4;
    return true;
  }

  const std::vector<Field>* findType(const std::string& type) const {
    const auto found = definitions_.types.find(type);
    return found == definitions_.types.end() ? nullptr : &found->second;
  }

  bool walkType(const std::string& type, int depth) {
    if (depth > 32) return fail(type + ": nested too deeply");
    const std::vector<Field>* fields = findType(type);
    if (!fields) return fail("unknown type " + type + " in the message definition");
    for (const Field& field : *fields) {
      if (!walkField(field, depth)) return false;
    }
    return true;
  }

  bool walkElements(const Field& field, std::uint64_t count, int depth) {
    const std::size_t size = builtinSize(field.type);
    if (size > 0) {
      if (count * size > left()) {
        return fail(field.name + ": " + std::to_string(count) + " elements of " +
                    std::to_string(size) + " bytes declared, " + std::to_string(left()) +
                    " bytes left");
      }
      offset_ += count * size;
      return true;
    }
    // Strings and messages take at least one byte (a string its 4-byte prefix): a count above
    // the bytes left is a lie however small the elements.
    if (count > left()) {
      return fail(field.name + ": " + std::to_string(count) + " elements declared, " +
                  std::to_string(left()) + " bytes left");
    }
    for (std::uint64_t i = 0; i < count; ++i) {
      if (field.type == "string") {
        std::uint32_t length = 0;
        if (!readLength(field.name, &length)) return false;
        if (length > left()) {
          return fail(field.name + ": a string of " + std::to_string(length) + " bytes declared, " +
                      std::to_string(left()) + " bytes left");
        }
        offset_ += length;
      } else if (!walkType(field.type, depth + 1)) {
        return false;
      }
    }
    return true;
  }

  bool walkField(const Field& field, int depth) {
    std::uint64_t count = 1;
    if (field.is_array) {
      if (field.fixed_length >= 0) {
        count = static_cast<std::uint64_t>(field.fixed_length);
      } else {
        std::uint32_t length = 0;
        if (!readLength(field.name, &length)) return false;
        count = length;
      }
    }
    return walkElements(field, count, depth);
  }

  const Definitions& definitions_;
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t offset_ = 0;
  std::string problem_;
};

}  // namespace

std::string checkSerializedMessage(const std::string& datatype, const std::string& definition,
                                   const std::uint8_t* data, std::size_t size) {
  // Parsed once per type and definition (images come at hundreds per second).
  static std::mutex mutex;
  static std::map<std::pair<std::string, std::string>, Definitions> parsed;
  const Definitions* definitions = nullptr;
  {
    std::lock_guard<std::mutex> lock(mutex);
    auto key = std::make_pair(datatype, definition);
    auto found = parsed.find(key);
    if (found == parsed.end()) {
      found = parsed.emplace(std::move(key), parseDefinitions(datatype, definition)).first;
    }
    definitions = &found->second;  // std::map nodes stay put
  }
  return Walker(*definitions, data, size).run();
}

}  // namespace sag_hand_tracker
