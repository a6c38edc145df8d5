#include "sag_hand_tracker/apps/command_line.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <set>
#include <sstream>

namespace sag_hand_tracker {

namespace {

// The largest value of an integer option (parseIntOption).
constexpr long kMaxIntOption = 1000000;

}  // namespace

const std::string& nextOptionValue(const std::vector<std::string>& args, size_t* i) {
  if (*i + 1 >= args.size() || args[*i + 1].rfind("--", 0) == 0) {
    throw UsageError(args[*i] + " needs a value");
  }
  // An explicitly empty value (`--root-frame ""`, `--model ""`) was taken as "the default" or
  // failed later as a missing file (exit status 1): it is a bad command line.
  if (args[*i + 1].empty()) throw UsageError(args[*i] + " needs a value, got an empty one");
  return args[++*i];
}

void rejectRepeatedOptions(const std::vector<std::string>& args) {
  std::set<std::string> seen;
  for (const std::string& arg : args) {
    if (arg.rfind("--", 0) != 0) continue;
    if (!seen.insert(arg).second) throw UsageError(arg + " is given twice");
  }
}

int parseIntOption(const std::string& option, const std::string& text, int min_value) {
  char* end = nullptr;
  errno = 0;
  const long value = std::strtol(text.c_str(), &end, 10);
  // strtol skips leading white space (" 10", "\n10" were taken); and 1000001 was refused as not
  // ">= 1", which it is.
  const bool parsed = !text.empty() && !std::isspace(static_cast<unsigned char>(text[0])) &&
                      *end == '\0' && errno != ERANGE;
  if (parsed && value > kMaxIntOption) {
    throw UsageError(option + " expects an integer of at most " + std::to_string(kMaxIntOption) +
                     ", got '" + text + "'");
  }
  if (!parsed || value < min_value) {
    throw UsageError(option + " expects an integer >= " + std::to_string(min_value) + ", got '" +
                     text + "'");
  }
  return static_cast<int>(value);
}

double parseDoubleOption(const std::string& option, const std::string& text, double min_value,
                         double max_value) {
  char* end = nullptr;
  errno = 0;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || std::isspace(static_cast<unsigned char>(text[0])) || *end != '\0' ||
      errno == ERANGE || !std::isfinite(value) || value < min_value || value > max_value) {
    std::ostringstream range;
    range << "[" << min_value << ", " << max_value << "]";
    throw UsageError(option + " expects a number within " + range.str() + ", got '" + text + "'");
  }
  return value;
}

std::vector<std::string> parseListOption(const std::string& option, const std::string& text,
                                         const std::string& what) {
  std::vector<std::string> items;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    if (item.empty()) throw UsageError(option + " expects " + what + ", got '" + text + "'");
    items.push_back(item);
  }
  if (items.empty() || text.back() == ',') {
    throw UsageError(option + " expects " + what + ", got '" + text + "'");
  }
  return items;
}

Handedness parseHandOption(const std::string& text) {
  if (text == "left") return Handedness::kLeft;
  if (text == "right") return Handedness::kRight;
  throw UsageError("--hand expects left or right, got '" + text + "'");
}

bool parseHandOrAutoOption(const std::string& text, Handedness* hand) {
  if (text == "auto") return true;
  if (text != "left" && text != "right") {
    throw UsageError("--hand expects left, right or auto, got '" + text + "'");
  }
  *hand = parseHandOption(text);
  return false;
}

}  // namespace sag_hand_tracker
