// libFuzzer target model_yaml (make fuzz); the work is sag_fuzz::fuzzModelYaml (fuzz_entries.h).
#include "fuzz_entries.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  sag_fuzz::fuzzModelYaml(data, size);
  return 0;
}
