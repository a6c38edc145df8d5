// Numbers as text: one form for error messages, one for tables and CSV files.
#pragma once

#include <string>

namespace sag_hand_tracker {

// The shortest stream form, six significant digits ("1e-300", "0.0001", "12", "nan"): how every
// error message prints a number it names.
std::string shortNumber(double value);

// `decimals` digits after the point ("12.35"); "-" for NaN (no value: a run without a pose),
// "inf" / "-inf" for infinities. The tables, CSV files and summaries of the offline tools.
std::string fixedNumber(double value, int decimals);

}  // namespace sag_hand_tracker
