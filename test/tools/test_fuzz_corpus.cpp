// Replays every seed and every saved crash input of the fuzz targets (test/fuzz/corpus/<target>/)
// through the same entry functions libFuzzer runs (test/fuzz/fuzz_entries.h), built normally:
// what the fuzzer once found stays fixed.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "../fuzz/fuzz_entries.h"

namespace fs = std::filesystem;

TEST(FuzzCorpus, EverySeedAndCrashInputIsHandled) {
  for (const sag_fuzz::FuzzTarget& target : sag_fuzz::fuzzTargets()) {
    const fs::path folder = fs::path(SAG_SOURCE_DIR) / "test/fuzz/corpus" / target.name;
    ASSERT_TRUE(fs::is_directory(folder)) << folder;
    std::vector<fs::path> inputs;
    for (const auto& entry : fs::directory_iterator(folder)) inputs.push_back(entry.path());
    std::sort(inputs.begin(), inputs.end());
    EXPECT_GE(inputs.size(), 2u) << "a seed corpus for " << target.name;
    for (const fs::path& input : inputs) {
      SCOPED_TRACE(input.string());
      std::ifstream file(input, std::ios::binary);
      const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(file)),
                                            std::istreambuf_iterator<char>());
      // InputError is handled inside; a crash, another exception or a finding fails here.
      EXPECT_NO_THROW(target.entry(bytes.data(), bytes.size()));
    }
  }
}
