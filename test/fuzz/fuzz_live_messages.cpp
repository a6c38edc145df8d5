// libFuzzer target live_messages (make fuzz); the work is sag_fuzz::fuzzLiveMessages
// (fuzz_entries.h).
#include "fuzz_entries.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  sag_fuzz::fuzzLiveMessages(data, size);
  return 0;
}
