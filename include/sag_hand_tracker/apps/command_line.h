// Command-line helpers shared by the offline tools: the usage error and the parsing of option
// values, so that every tool words its complaints the same way.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "sag_hand_tracker/model/hand_model.h"

namespace sag_hand_tracker {

// A bad command line; the message says what is wrong (without the usage text).
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The value of the option args[*i]: args[*i + 1], advancing *i; UsageError
// "<option> needs a value" when there is none or the next argument is an option itself.
const std::string& nextOptionValue(const std::vector<std::string>& args, size_t* i);

// `text` as an integer in [min_value, 1000000]; else UsageError
// "<option> expects an integer >= <min_value>, got '<text>'".
int parseIntOption(const std::string& option, const std::string& text, int min_value);

// The comma-separated items of `text`, none empty; else UsageError
// "<option> expects <what>, got '<text>'".
std::vector<std::string> parseListOption(const std::string& option, const std::string& text,
                                         const std::string& what = "a list like a,b,c");

// `text` ("left" or "right") as the hand of option --hand; else UsageError
// "--hand expects left or right, got '<text>'".
Handedness parseHandOption(const std::string& text);

}  // namespace sag_hand_tracker
