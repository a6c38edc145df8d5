// Writing hand models: the text of a model file (README.md, "Hand models"), for the fitted models
// of calibrate_hand. Implemented beside the reader in hand_model.cpp.
#pragma once

#include <string>

#include "sag_hand_tracker/hand_model.h"

namespace sag_hand_tracker {

// The model as a model file (the format loadHandModel reads; loading the text gives the same
// model up to rounding to 6 significant digits). `comment` becomes '#' lines at the top. Throws
// InputError for a model that fails validateHandModel.
std::string formatHandModel(const HandModel& model, const std::string& comment = "");

}  // namespace sag_hand_tracker
