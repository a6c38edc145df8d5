// Speed of the synthetic studio (issue 4 target: a 300-frame, 5-camera sequence in well under a
// minute on one core): one frame of 5 images of the default rig, with and without motion blur,
// and the one-off set-up (the precomputed background of every camera).
#include <benchmark/benchmark.h>

#include "sag_hand_tracker/camera/calibration.h"
#include "sag_hand_tracker/model/hand_model.h"
#include "sag_hand_tracker/studio/motion.h"
#include "sag_hand_tracker/studio/renderer.h"
#include "sag_hand_tracker/studio/sequence.h"

namespace {

using namespace sag_hand_tracker;

const std::string kConfig = std::string(SAG_SOURCE_DIR) + "/config";

const std::vector<Camera>& rigCameras() {
  static const std::vector<Camera> cameras =
      loadCameraRig(kConfig + "/rigs/dexter5/rig.yaml").cameras;
  return cameras;
}

studio::StudioSequence makeSequence(int motion_blur_samples) {
  const HandModel model = loadHandModel(resolveModelPath("sag", kConfig));
  studio::SequenceParams params;
  params.motion_blur_samples = motion_blur_samples;
  return studio::StudioSequence(
      model, studio::loadMotion(studio::resolveMotionPath("random", kConfig), model, 1), params);
}

// Surfaces + 5 images (shadow, shading, blur, noise) per frame, over the frames of `random`.
void BM_StudioFrame(benchmark::State& state) {
  studio::StudioRenderer renderer(rigCameras());
  renderer.setRenderThreads(static_cast<int>(state.range(1)));
  const studio::StudioSequence sequence = makeSequence(static_cast<int>(state.range(0)));
  int frame = 10;
  for (auto _ : state) {
    const auto images = renderer.render(sequence.surfaces(frame), sequence.noiseSeed(frame));
    benchmark::DoNotOptimize(images.data());
    frame = frame + 1 < sequence.frameCount() ? frame + 1 : 10;
  }
  state.counters["frames/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_StudioFrame)
    ->ArgNames({"subframes", "threads"})
    ->Args({1, 1})
    ->Args({1, 2})
    ->Args({4, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_StudioSetup(benchmark::State& state) {
  for (auto _ : state) {
    const studio::StudioRenderer renderer(rigCameras());
    benchmark::DoNotOptimize(&renderer);
  }
}
BENCHMARK(BM_StudioSetup)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
