// Command-line helpers shared by the offline tools: the usage error and the parsing of option
// values, so that every tool words its complaints the same way.
#pragma once

#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "sag_hand_tracker/model/hand_model.h"

namespace sag_hand_tracker {

// A bad command line; the message says what is wrong (without the usage text).
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The value of the option args[*i]: args[*i + 1], advancing *i; UsageError
// "<option> needs a value" when there is none or the next argument is an option itself, and
// "<option> needs a value, got an empty one" when it is "" (never "use the default").
const std::string& nextOptionValue(const std::vector<std::string>& args, size_t* i);

// UsageError "<option> is given twice" when an option (an argument beginning with "--") appears
// more than once: the tools would otherwise take the last value and silently ignore the first
// (two --out, two --bag). Every tool's parser calls it first.
void rejectRepeatedOptions(const std::vector<std::string>& args);

// `text` as an integer in [min_value, 1000000] (no leading white space); else UsageError
// "<option> expects an integer >= <min_value>, got '<text>'", or "<option> expects an integer of
// at most 1000000, got '<text>'" above the limit.
int parseIntOption(const std::string& option, const std::string& text, int min_value);
// A finite number within [min_value, max_value]; UsageError naming the option otherwise.
double parseDoubleOption(const std::string& option, const std::string& text, double min_value,
                         double max_value);

// The comma-separated items of `text`, none empty; else UsageError
// "<option> expects <what>, got '<text>'".
std::vector<std::string> parseListOption(const std::string& option, const std::string& text,
                                         const std::string& what = "a list like a,b,c");

// `text` ("left" or "right") as the hand of option --hand; else UsageError
// "--hand expects left or right, got '<text>'".
Handedness parseHandOption(const std::string& text);
// The same for a tool that also takes "auto" (track_bag): returns true for "auto" and leaves
// *hand alone; else UsageError "--hand expects left, right or auto, got '<text>'".
bool parseHandOrAutoOption(const std::string& text, Handedness* hand);

// Whether a tool's options have `hand_auto`, i.e. take --hand auto (parseBagToolOption).
template <typename Options, typename = void>
struct TakesHandAuto : std::false_type {};
template <typename Options>
struct TakesHandAuto<Options, std::void_t<decltype(std::declval<Options&>().hand_auto)>>
    : std::true_type {};

// The options that the bag tools (track_bag, calibrate_hand) share: --help/-h, --bag, --out,
// --model, --hand, --background-frames (>= 0) and --quiet, stored in the members of `options`
// of the same names (--hand auto in `hand_auto` for the tools that have it). Returns false when
// args[*i] is none of them; otherwise takes its value (advancing *i) and returns true.
template <typename Options>
bool parseBagToolOption(const std::vector<std::string>& args, size_t* i, Options* options) {
  const std::string& arg = args[*i];
  if (arg == "--help" || arg == "-h") {
    options->help = true;
  } else if (arg == "--bag") {
    options->bag = nextOptionValue(args, i);
  } else if (arg == "--out") {
    options->out = nextOptionValue(args, i);
  } else if (arg == "--model") {
    options->model = nextOptionValue(args, i);
  } else if (arg == "--hand") {
    if constexpr (TakesHandAuto<Options>::value) {
      options->hand_auto = parseHandOrAutoOption(nextOptionValue(args, i), &options->hand);
    } else {
      options->hand = parseHandOption(nextOptionValue(args, i));
    }
  } else if (arg == "--background-frames") {
    options->background_frames = parseIntOption(arg, nextOptionValue(args, i), 0);
  } else if (arg == "--quiet") {
    options->quiet = true;
  } else {
    return false;
  }
  return true;
}

// UsageError when a bag tool was given no --bag or no --out (and no --help).
template <typename Options>
void requireBagAndOut(const Options& options) {
  if (options.help) return;
  if (options.bag.empty()) throw UsageError("--bag is required");
  if (options.out.empty()) throw UsageError("--out is required");
}

}  // namespace sag_hand_tracker
