// libFuzzer target motion_yaml (make fuzz); the work is sag_fuzz::fuzzMotionYaml (fuzz_entries.h).
#include "fuzz_entries.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  sag_fuzz::fuzzMotionYaml(data, size);
  return 0;
}
