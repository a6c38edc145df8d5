#include "sag_hand_tracker/util/number_text.h"

#include <cmath>
#include <cstdio>
#include <sstream>

namespace sag_hand_tracker {

std::string shortNumber(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

std::string fixedNumber(double value, int decimals) {
  if (std::isnan(value)) return "-";
  if (std::isinf(value)) return value > 0.0 ? "inf" : "-inf";
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", decimals, value);
  return text;
}

}  // namespace sag_hand_tracker
