// The tracker per set: an ordinary tracking step, and the start (the hypothesis search that the
// live graph's worker runs while the sets wait for it; its wall time decides how many sets of a
// start come late, doc/demo.md). 5 cameras, observations rendered from the model itself.
#include <benchmark/benchmark.h>

#include <cmath>

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

namespace {

// A hand rolling to and fro about its wrist->knuckle axis (±0.6 rad, 50 frames a period), so that
// every step after the first has a turn and the counter-turn start runs; the sets are made once,
// and the period repeats without a jump.
std::vector<std::vector<CameraObservation>> rollingHand(const HandModel& model) {
  const Pose rest = typicalPose(model);
  const std::vector<Camera> cameras = fiveCameraRig();
  const Eigen::Vector3d centre = rest.translation + rest.rotation * Eigen::Vector3d(0.065, 0, 0);
  std::vector<std::vector<CameraObservation>> sets;
  constexpr int kPeriod = 50;
  for (int k = 0; k < kPeriod; ++k) {
    Pose pose = rest;
    const double angle = 0.6 * std::sin(2.0 * M_PI * k / kPeriod);
    pose.rotation =
        rest.rotation * Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitX()).toRotationMatrix();
    pose.translation = centre - pose.rotation * Eigen::Vector3d(0.065, 0, 0);
    sets.push_back(modelObservations(model, pose, cameras, 3.0));
  }
  return sets;
}

}  // namespace

// Tracking steps of a turning hand, with the counter-turn start's two ascents raced
// (TrackerParams::counter_turn_race_share: 50 = the default half) or both whole (0).
static void BM_TrackerStepTurning(benchmark::State& state) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<std::vector<CameraObservation>> sets = rollingHand(model);
  TrackerParams params;
  params.redetect_interval = 0;
  params.counter_turn_race_share = state.range(0) / 100.0;
  HandTracker tracker(model, params);
  tracker.update(sets[0], 0.0);
  size_t k = 0;
  double stamp = 0.0;
  for (auto _ : state) {
    k = (k + 1) % sets.size();
    stamp += 0.04;
    const FrameResult result = tracker.update(sets[k], stamp);
    if (!result.has_pose) state.SkipWithError("lost the rolling hand");
    benchmark::DoNotOptimize(result.pose.translation.x());
  }
}
BENCHMARK(BM_TrackerStepTurning)
    ->ArgName("race_share_pct")
    ->Arg(0)
    ->Arg(50)
    ->Unit(benchmark::kMillisecond);

// A tracking step with a re-detection on every set (redetect_interval 1): the search with a pose,
// its last stage raced (TrackerParams::redetect_race_iterations: 5 = the default) or whole (0).
static void BM_TrackerRedetection(benchmark::State& state) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<CameraObservation> observations = handObservations(model);
  TrackerParams params;
  params.redetect_interval = 1;
  params.redetect_race_iterations = static_cast<int>(state.range(0));
  HandTracker tracker(model, params);
  tracker.update(observations, 0.0);
  double stamp = 0.0;
  for (auto _ : state) {
    stamp += 0.04;
    const FrameResult result = tracker.update(observations, stamp);
    if (!result.has_pose) state.SkipWithError("the re-detection lost the hand");
    benchmark::DoNotOptimize(result.pose.translation.x());
  }
}
BENCHMARK(BM_TrackerRedetection)
    ->ArgName("race_iterations")
    ->Arg(0)
    ->Arg(5)
    ->Unit(benchmark::kMillisecond);
