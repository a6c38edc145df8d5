#include "sag_hand_tracker/util/input_limits.h"

#include <cctype>

#include "sag_hand_tracker/util/types.h"

namespace sag_hand_tracker {

bool isSafeName(const std::string& name) {
  if (name.empty() || name.size() > 256) return false;
  if (!std::isalpha(static_cast<unsigned char>(name[0]))) return false;
  for (const char c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
  }
  return true;
}

void checkImageSize(std::int64_t width, std::int64_t height, const std::string& who) {
  const std::string size = std::to_string(width) + "x" + std::to_string(height);
  if (width <= 0 || height <= 0) throw InputError(who + ": image size " + size + " is empty");
  if (width > kMaxImageSide || height > kMaxImageSide || width * height > kMaxImagePixels) {
    throw InputError(who + ": image size " + size + " exceeds the limit (sides up to " +
                     std::to_string(kMaxImageSide) + ", at most " +
                     std::to_string(kMaxImagePixels) + " pixels)");
  }
}

}  // namespace sag_hand_tracker
