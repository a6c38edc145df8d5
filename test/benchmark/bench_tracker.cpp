// The tracker per set: an ordinary tracking step, and the start (the hypothesis search that the
// live graph's worker runs while the sets wait for it; its wall time decides how many sets of a
// start come late, doc/demo.md). 5 cameras, observations rendered from the model itself.
#include <benchmark/benchmark.h>

#include "sag_hand_tracker/tracking/tracker.h"
#include "test_support/synthetic_scene.h"

using namespace sag_hand_tracker;
using namespace sag_test;

namespace {

std::vector<CameraObservation> handObservations(const HandModel& model) {
  return modelObservations(model, typicalPose(model), fiveCameraRig(), 3.0);
}

}  // namespace

// A start from nothing: the synchronous search of a fresh tracker, on 1 or 2 threads
// (TrackerParams::search_threads; the live worker's default is 2). Wall time is what counts here:
// the sets wait for it.
static void BM_TrackerStart(benchmark::State& state) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<CameraObservation> observations = handObservations(model);
  TrackerParams params;
  params.search_threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    HandTracker tracker(model, params);
    const FrameResult result = tracker.update(observations, 0.0);
    if (!result.has_pose) state.SkipWithError("the start found no hand");
    benchmark::DoNotOptimize(result.pose.translation.x());
  }
}
BENCHMARK(BM_TrackerStart)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// One tracking step of a started tracker (no re-detection: the interval is never reached).
static void BM_TrackerStep(benchmark::State& state) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<CameraObservation> observations = handObservations(model);
  TrackerParams params;
  params.redetect_interval = 0;
  HandTracker tracker(model, params);
  tracker.update(observations, 0.0);
  double stamp = 0.0;
  for (auto _ : state) {
    stamp += 0.04;
    const FrameResult result = tracker.update(observations, stamp);
    benchmark::DoNotOptimize(result.pose.translation.x());
  }
}
BENCHMARK(BM_TrackerStep)->Unit(benchmark::kMillisecond);
