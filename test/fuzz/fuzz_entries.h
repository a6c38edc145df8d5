// The entry functions of the fuzz targets (libFuzzer, `make fuzz`) and of the gtest that replays
// every seed and every saved crash input in `make test` (test/tools/test_fuzz_corpus.cpp): the
// same code for both. Each takes arbitrary bytes; bad input must end in InputError (caught
// here), never in a crash, a hang, another exception or a non-finite result (which abort).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace sag_fuzz {

// Hand model YAML -> parseHandModel (then mirrored and posed at the neutral pose).
void fuzzModelYaml(const std::uint8_t* data, std::size_t size);
// Rig YAML and camera calibration YAML, separated by a line "%%" -> parseCameraRig with that
// calibration for every camera (also parsed alone), then validateCamera and undistortion.
void fuzzRigYaml(const std::uint8_t* data, std::size_t size);
// Motion YAML for the built-in SAG model -> parseMotion, then poses across its duration.
void fuzzMotionYaml(const std::uint8_t* data, std::size_t size);
// A bag file -> BagReader, every frame set read.
void fuzzBag(const std::uint8_t* data, std::size_t size);
// The first byte picks SumOfGaussians, CameraInfo or Image; the rest fills its fields ->
// sogFromMsg, fromCameraInfo (then undistortion), toRgbMat.
void fuzzMessages(const std::uint8_t* data, std::size_t size);

// The first byte picks SumOfGaussians, CameraInfo or HandRegion; the rest is the message's bytes
// as they arrive from another process -> the live subscriptions' check and roscpp's deserializer
// (ros/checked_subscription.h), then sogFromMsg / fromCameraInfo on what it accepts.
void fuzzLiveMessages(const std::uint8_t* data, std::size_t size);

struct FuzzTarget {
  std::string name;  // also the folder test/fuzz/corpus/<name>/
  void (*entry)(const std::uint8_t*, std::size_t);
};
const std::vector<FuzzTarget>& fuzzTargets();

}  // namespace sag_fuzz
