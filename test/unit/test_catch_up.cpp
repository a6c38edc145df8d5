// The catch-up of the asynchronous search (issue 12, TrackerParams::catch_up_seconds): a worker
// tracks the set that asked for a search and every set after it as the synchronous tracker does;
// the sets the frame path reported without a pose meanwhile get the worker's poses afterwards, in
// order, and the frame path then goes on from the worker's state. The workers are held on a gate
// (HandTracker::holdSearchesUntil), so that the tests decide how many sets arrive meanwhile.
#include <gtest/gtest.h>

#include <atomic>
#include <future>
#include <map>
#include <vector>

#include "sag_hand_tracker/apps/metrics.h"
#include "sag_hand_tracker/tracking/tracker.h"
#include "test_support/synthetic_scene.h"

using namespace sag_hand_tracker;
using namespace sag_test;

namespace {

constexpr double kFramePeriod = 0.04;  // 25 fps
constexpr std::int64_t kFirstId = 1000;

// The moving hand of frame `frame`.
Pose movingHand(const HandModel& model, int frame) {
  Pose truth = typicalPose(model);
  truth.translation.x() += 0.003 * frame;
  truth.joints[4] = 0.2 + 0.4 * std::sin(frame * 0.2);
  return truth;
}

// Every result of a run, the late ones included, by frame id; fails on a frame id reported with
// a pose twice.
struct TrackedRun {
  std::map<std::int64_t, FrameResult> posed;
  std::vector<std::int64_t> order;  // frame ids of the results with a pose, as returned
};

void addPosed(const FrameResult& result, TrackedRun* run) {
  if (!result.has_pose) return;
  EXPECT_TRUE(result.pose.allFinite());
  EXPECT_EQ(run->posed.count(result.frame_id), 0u) << "frame " << result.frame_id << " twice";
  run->posed[result.frame_id] = result;
  run->order.push_back(result.frame_id);
}

// An update's late results, then its own result.
void collect(const std::vector<FrameResult>& late_results, const FrameResult& result,
             TrackedRun* run) {
  for (const FrameResult& late : late_results) {
    EXPECT_TRUE(late.late);
    EXPECT_TRUE(late.has_pose);
    addPosed(late, run);
  }
  EXPECT_FALSE(result.late);
  addPosed(result, run);
}

// The tracker a live graph's worker is: `params` searching on the frame path, on one thread.
TrackerParams synchronousParams(TrackerParams params) {
  params.asynchronous_search = false;
  params.search_threads = 1;
  return params;
}

double fingertipDifference(const FrameResult& a, const FrameResult& b) {
  return meanFingertipError(a.fingertips, b.fingertips);
}

}  // namespace

// The start: the search for the first set is held while five more sets arrive; all six are
// waiting then, and the update after the search has finished returns their poses as late results,
// in order, with their frame ids and stamps, equal to a synchronous tracker's.
TEST(TrackerCatchUp, EverySetDuringTheStartSearchGetsItsPoseAfterwards) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  TrackerParams params;
  params.asynchronous_search = true;
  params.search_threads = 3;  // the worker searches on three threads, the reference on one
  HandTracker tracker(model, params);
  std::promise<void> gate;
  tracker.holdSearchesUntil(gate.get_future().share());
  HandTracker synchronous(model, synchronousParams(params));

  constexpr int kHeld = 6, kFrames = 10;
  TrackedRun run;
  std::map<std::int64_t, FrameResult> expected;
  for (int frame = 0; frame < kFrames; ++frame) {
    const std::vector<CameraObservation> observations =
        modelObservations(model, movingHand(model, frame), cameras, 3.0);
    const double stamp = frame * kFramePeriod;
    expected[kFirstId + frame] = synchronous.update(observations, stamp, kFirstId + frame);
    if (frame == kHeld) {
      EXPECT_EQ(tracker.keptFrames(), kHeld);
      gate.set_value();
      tracker.waitForSearch();
    }
    const FrameResult result = tracker.update(observations, stamp, kFirstId + frame);
    EXPECT_EQ(result.frame_id, kFirstId + frame);
    EXPECT_DOUBLE_EQ(result.stamp, stamp);
    const std::vector<FrameResult> late = tracker.takeLateResults();
    if (frame < kHeld) {
      EXPECT_FALSE(result.has_pose) << "frame " << frame;
      EXPECT_EQ(result.status, TrackStatus::kWaiting) << "frame " << frame;
      EXPECT_TRUE(tracker.searching());
      EXPECT_TRUE(late.empty());
      continue;
    }
    ASSERT_TRUE(result.has_pose) << "frame " << frame;
    EXPECT_EQ(result.status, TrackStatus::kTracking) << "frame " << frame;
    if (frame == kHeld) {
      ASSERT_EQ(late.size(), static_cast<size_t>(kHeld));
      for (int i = 0; i < kHeld; ++i) {
        EXPECT_EQ(late[i].frame_id, kFirstId + i);
        EXPECT_DOUBLE_EQ(late[i].stamp, i * kFramePeriod);
        EXPECT_EQ(late[i].status, i == 0 ? TrackStatus::kStarted : TrackStatus::kTracking);
        EXPECT_FALSE(late[i].restarted);  // the first start, not a restart
      }
      EXPECT_EQ(tracker.keptFrames(), 0);
    } else {
      EXPECT_TRUE(late.empty()) << "frame " << frame;
    }
    collect(late, result, &run);
  }
  // Every set has a pose, reported in order, and it is the synchronous tracker's.
  ASSERT_EQ(run.order.size(), static_cast<size_t>(kFrames));
  for (int frame = 0; frame < kFrames; ++frame) {
    const std::int64_t id = kFirstId + frame;
    EXPECT_EQ(run.order[frame], id);
    ASSERT_TRUE(expected[id].has_pose);
    EXPECT_LT(fingertipDifference(run.posed[id], expected[id]), 1e-6) << "frame " << frame;
    EXPECT_EQ(run.posed[id].status, expected[id].status) << "frame " << frame;
    EXPECT_LT(
        meanFingertipError(run.posed[id].fingertips, fingertips(model, movingHand(model, frame))),
        0.02)
        << "frame " << frame;
  }
}

// A lost track: the hand jumps away, the worker that restarts it is held for four sets; they get
// their poses afterwards, close to the truth and equal to a synchronous tracker's (the worker
// restarts on the jump's set itself, as the synchronous tracker does), and the frame path goes on
// from the worker's state.
TEST(TrackerCatchUp, EverySetDuringARestartSearchGetsItsPoseAfterwards) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  TrackerParams params;
  params.asynchronous_search = true;
  params.search_threads = 2;
  params.redetect_interval = 0;  // only the restart searches
  HandTracker tracker(model, params);
  std::promise<void> gate;
  HandTracker synchronous(model, synchronousParams(params));

  constexpr int kTracked = 8, kHeld = 4, kFrames = kTracked + kHeld + 4;
  const Eigen::Vector3d jump(-0.1, 0.2, 0.05);
  TrackedRun run;
  std::map<std::int64_t, FrameResult> expected;
  std::map<std::int64_t, Pose> truths;
  for (int frame = 0; frame < kFrames; ++frame) {
    Pose truth = movingHand(model, frame);
    if (frame >= kTracked) truth.translation += jump;
    const std::int64_t id = kFirstId + frame;
    truths[id] = truth;
    const std::vector<CameraObservation> observations =
        modelObservations(model, truth, cameras, 3.0);
    const double stamp = frame * kFramePeriod;
    expected[id] = synchronous.update(observations, stamp, id);
    if (frame == kTracked + 1 + kHeld) {
      // The jump's set too when it got no pose.
      EXPECT_GE(tracker.keptFrames(), kHeld);
      EXPECT_LE(tracker.keptFrames(), kHeld + 1);
      gate.set_value();
      tracker.waitForSearch();
    }
    const FrameResult result = tracker.update(observations, stamp, id);
    if (frame == 0) {
      tracker.waitForSearch();  // the first start; frame 1 collects it (catch-up of frame 0)
    }
    if (frame == 1) {
      // Started (the first search, not held) and tracking: hold the next one.
      ASSERT_TRUE(result.has_pose);
      ASSERT_FALSE(tracker.searching());
      tracker.holdSearchesUntil(gate.get_future().share());
    }
    if (frame == kTracked) {
      EXPECT_EQ(result.status, TrackStatus::kLost);
      EXPECT_TRUE(tracker.searching());
    }
    if (frame > kTracked && frame <= kTracked + kHeld) {
      EXPECT_FALSE(result.has_pose) << "frame " << frame;
      EXPECT_EQ(result.status, TrackStatus::kLost) << "frame " << frame;
    }
    if (frame == kTracked + 1 + kHeld) {
      ASSERT_TRUE(result.has_pose);
      EXPECT_EQ(result.status, TrackStatus::kTracking);
    }
    collect(tracker.takeLateResults(), result, &run);
  }
  // Every set has a pose (the jump's own set is reported lost, with the warm-started pose when that
  // is plausible, else late), reported in frame order, and from the jump on it is the synchronous
  // tracker's, which restarted on the jump's set.
  ASSERT_EQ(run.order.size(), static_cast<size_t>(kFrames));
  EXPECT_TRUE(expected[kFirstId + kTracked].restarted);
  for (int frame = 0; frame < kFrames; ++frame) {
    const std::int64_t id = kFirstId + frame;
    EXPECT_EQ(run.order[frame], id);
    const FrameResult& result = run.posed[id];
    if (frame < kTracked) continue;
    if (frame == kTracked && !result.late) {
      EXPECT_EQ(result.status, TrackStatus::kLost);
      continue;
    }
    EXPECT_EQ(result.late, frame <= kTracked + kHeld) << "frame " << frame;
    EXPECT_EQ(result.status, expected[id].status) << "frame " << frame;
    EXPECT_EQ(result.restarted, expected[id].restarted) << "frame " << frame;
    EXPECT_LT(meanFingertipError(result.fingertips, fingertips(model, truths[id])), 0.025)
        << "frame " << frame;
    ASSERT_TRUE(expected[id].has_pose) << "frame " << frame;
    EXPECT_LT(fingertipDifference(result, expected[id]), 1e-9) << "frame " << frame;
  }
}

// The bound: with catch_up_seconds 0.1 at 25 fps the held worker keeps only the sets of the last
// 0.1 s; the older ones stay as they were reported (waiting, no pose), and the worker's search
// runs on the oldest set it kept.
TEST(TrackerCatchUp, KeepsOnlyTheSetsWithinItsBound) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  TrackerParams params;
  params.asynchronous_search = true;
  params.catch_up_seconds = 0.1;
  HandTracker tracker(model, params);
  std::promise<void> gate;
  tracker.holdSearchesUntil(gate.get_future().share());
  constexpr int kHeld = 6;
  for (int frame = 0; frame <= kHeld; ++frame) {
    if (frame == kHeld) {
      EXPECT_EQ(tracker.keptFrames(), 3);  // stamps 0.12, 0.16, 0.20
      gate.set_value();
      tracker.waitForSearch();
    }
    const FrameResult result =
        tracker.update(modelObservations(model, movingHand(model, frame), cameras, 3.0),
                       frame * kFramePeriod, kFirstId + frame);
    EXPECT_EQ(result.has_pose, frame == kHeld) << "frame " << frame;
  }
  const std::vector<FrameResult> late = tracker.takeLateResults();
  ASSERT_EQ(late.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(late[i].frame_id, kFirstId + 3 + i);
    EXPECT_TRUE(late[i].has_pose);
    EXPECT_LT(meanFingertipError(late[i].fingertips, fingertips(model, movingHand(model, 3 + i))),
              0.02);
  }
  EXPECT_EQ(late[0].status, TrackStatus::kStarted);

  // catch_up_seconds 0: the worker keeps only the newest set and no late results come back; the
  // frame path goes on from the track the worker started on that set.
  params.catch_up_seconds = 0.0;
  HandTracker without(model, params);
  std::promise<void> second_gate;
  without.holdSearchesUntil(second_gate.get_future().share());
  for (int frame = 0; frame < 3; ++frame) {
    without.update(modelObservations(model, movingHand(model, frame), cameras, 3.0),
                   frame * kFramePeriod, frame);
  }
  EXPECT_EQ(without.keptFrames(), 1);
  second_gate.set_value();
  without.waitForSearch();
  const FrameResult tracked = without.update(
      modelObservations(model, movingHand(model, 3), cameras, 3.0), 3 * kFramePeriod, 3);
  EXPECT_TRUE(tracked.has_pose);
  EXPECT_EQ(tracked.status, TrackStatus::kTracking);
  EXPECT_LT(meanFingertipError(tracked.fingertips, fingertips(model, movingHand(model, 3))), 0.02);
  EXPECT_TRUE(without.takeLateResults().empty());
  EXPECT_FALSE(without.searching());
}

// A reset drops the kept sets with the search.
TEST(TrackerCatchUp, ResetDropsTheKeptSets) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  TrackerParams params;
  params.asynchronous_search = true;
  HandTracker tracker(model, params);
  std::promise<void> gate;
  tracker.holdSearchesUntil(gate.get_future().share());
  for (int frame = 0; frame < 3; ++frame) {
    tracker.update(modelObservations(model, movingHand(model, frame), cameras, 3.0),
                   frame * kFramePeriod, frame);
  }
  EXPECT_EQ(tracker.keptFrames(), 3);
  gate.set_value();  // the worker must not wait for ever on a dropped search
  tracker.reset();
  EXPECT_EQ(tracker.keptFrames(), 0);
  EXPECT_FALSE(tracker.searching());
}

// The worker searches again wherever the synchronous tracker would: the search for an empty set
// (no camera sees the hand) finds nothing, so the next set searches again, and the sets with the
// hand get their poses, the first one starting the track, once the worker has tracked them all.
TEST(TrackerCatchUp, TheWorkerSearchesAgainWhereTheSynchronousTrackerWould) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  TrackerParams params;
  params.asynchronous_search = true;
  HandTracker tracker(model, params);
  std::promise<void> gate;
  tracker.holdSearchesUntil(gate.get_future().share());
  constexpr int kEmpty = 2, kFirstHand = kEmpty;
  auto observationsOf = [&](int frame) {
    return frame < kEmpty ? std::vector<CameraObservation>()
                          : modelObservations(model, movingHand(model, frame), cameras, 3.0);
  };
  auto update = [&](int frame) {
    return tracker.update(observationsOf(frame), frame * kFramePeriod, kFirstId + frame);
  };
  for (int frame = 0; frame < 5; ++frame) EXPECT_FALSE(update(frame).has_pose);
  EXPECT_EQ(tracker.keptFrames(), 5);
  gate.set_value();
  tracker.waitForSearch();
  EXPECT_EQ(tracker.keptFrames(), 0);
  const FrameResult result = update(5);
  ASSERT_TRUE(result.has_pose);
  EXPECT_EQ(result.status, TrackStatus::kTracking);
  const std::vector<FrameResult> late = tracker.takeLateResults();
  ASSERT_EQ(late.size(), 3u);  // sets 0 and 1 have no hand: no pose
  for (int i = 0; i < 3; ++i) {
    const int frame = kFirstHand + i;
    EXPECT_EQ(late[i].frame_id, kFirstId + frame);
    EXPECT_TRUE(late[i].late);
    EXPECT_EQ(late[i].status, i == 0 ? TrackStatus::kStarted : TrackStatus::kTracking);
    EXPECT_LT(meanFingertipError(late[i].fingertips, fingertips(model, movingHand(model, frame))),
              0.02)
        << "frame " << frame;
  }
  EXPECT_FALSE(tracker.searching());
}

// A periodic re-detection on the worker: the frame path keeps tracking every set on time while
// the worker, held for three sets, re-tracks them with the synchronous search; once adopted, the
// frame path's state is the synchronous tracker's, so every later set gets exactly its pose.
TEST(TrackerCatchUp, AfterARedetectionTheFramePathGoesOnAsTheSynchronousTracker) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  TrackerParams params;
  params.asynchronous_search = true;
  params.redetect_interval = 5;
  HandTracker tracker(model, params);
  HandTracker synchronous(model, synchronousParams(params));
  std::promise<void> gate;
  int held = 0, adopted_then_compared = 0;
  bool adopted = false;
  for (int frame = 0; frame < 20; ++frame) {
    const std::vector<CameraObservation> observations =
        modelObservations(model, movingHand(model, frame), cameras, 3.0);
    const FrameResult expected = synchronous.update(observations, frame * kFramePeriod, frame);
    const bool was_searching = tracker.searching();
    const FrameResult result = tracker.update(observations, frame * kFramePeriod, frame);
    // Every set but the first (its late result comes with the second) had a pose on time.
    EXPECT_EQ(tracker.takeLateResults().size(), frame == 1 ? 1u : 0u) << "frame " << frame;
    if (frame == 0) {
      tracker.waitForSearch();  // the start, not held
      tracker.holdSearchesUntil(gate.get_future().share());
      continue;
    }
    ASSERT_TRUE(result.has_pose) << "frame " << frame;
    if (adopted) {
      // From here on the synchronous tracker's poses and statuses.
      EXPECT_LT(fingertipDifference(result, expected), 1e-9) << "frame " << frame;
      EXPECT_EQ(result.status, expected.status) << "frame " << frame;
      ++adopted_then_compared;
    }
    if (tracker.searching() && held < 3) {
      ++held;
      if (held == 3) {
        gate.set_value();
        tracker.waitForSearch();
        EXPECT_EQ(tracker.keptFrames(), 0);
      }
    } else if (was_searching) {
      adopted = true;
    }
  }
  EXPECT_EQ(held, 3);
  EXPECT_TRUE(adopted);
  EXPECT_GT(adopted_then_compared, 10);
}

// A requested re-detection (HandTracker::requestRedetection, the live tracker's search in a
// started hand's region) with the asynchronous search: the request goes with its set to the
// worker, which re-tracks it with the synchronous search (every candidate adopted here); once the
// worker is adopted, the frame path goes on exactly as a synchronous tracker asked the same.
TEST(TrackerCatchUp, ARequestedRedetectionGoesToTheWorkerWithItsSet) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  TrackerParams params;
  params.asynchronous_search = true;
  params.redetect_interval = 0;
  params.redetect_margin = -1.0;
  HandTracker tracker(model, params);
  HandTracker synchronous(model, synchronousParams(params));
  constexpr int kRequested = 6, kFrames = 14;
  bool searched = false;
  int compared = 0;
  for (int frame = 0; frame < kFrames; ++frame) {
    const std::vector<CameraObservation> observations =
        modelObservations(model, movingHand(model, frame), cameras, 3.0);
    if (frame == kRequested) {
      tracker.requestRedetection();
      synchronous.requestRedetection();
    }
    const FrameResult expected = synchronous.update(observations, frame * kFramePeriod, frame);
    const FrameResult result = tracker.update(observations, frame * kFramePeriod, frame);
    tracker.takeLateResults();
    if (frame == 0 || frame == kRequested) {
      if (frame == kRequested) {
        searched = tracker.searching();
        EXPECT_TRUE(expected.restarted);  // the synchronous search adopted its candidate
      }
      tracker.waitForSearch();
      continue;
    }
    ASSERT_TRUE(result.has_pose) << "frame " << frame;
    if (frame > kRequested) {
      EXPECT_LT(fingertipDifference(result, expected), 1e-9) << "frame " << frame;
      EXPECT_EQ(result.status, expected.status) << "frame " << frame;
      ++compared;
    }
  }
  EXPECT_TRUE(searched);
  EXPECT_EQ(compared, kFrames - kRequested - 1);
}

// The live graph publishes a late result as soon as the worker has it: the worker calls the late
// result callback once per set it found a pose for that the frame path had reported without one,
// and takeReadyLateResults hands those results over between updates, in order, equal to the ones
// the next update would have returned; that update then returns none, and goes on from the
// worker's track. Sets the frame path had a pose for (a re-detection's) call it not.
TEST(TrackerCatchUp, LateResultsAreReadyBeforeTheNextSetAndAreSignalled) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  TrackerParams params;
  params.asynchronous_search = true;
  params.redetect_interval = 3;
  HandTracker tracker(model, params);
  std::atomic<int> signals{0};
  tracker.setLateResultCallback([&signals]() { ++signals; });
  std::promise<void> gate;
  tracker.holdSearchesUntil(gate.get_future().share());
  HandTracker reference(model, params);  // collects its late results at the next update
  std::promise<void> reference_gate;
  reference.holdSearchesUntil(reference_gate.get_future().share());

  constexpr int kHeld = 4;
  auto observationsOf = [&](int frame) {
    return modelObservations(model, movingHand(model, frame), cameras, 3.0);
  };
  for (int frame = 0; frame < kHeld; ++frame) {
    EXPECT_FALSE(
        tracker.update(observationsOf(frame), frame * kFramePeriod, kFirstId + frame).has_pose);
    reference.update(observationsOf(frame), frame * kFramePeriod, kFirstId + frame);
  }
  EXPECT_TRUE(tracker.takeReadyLateResults().empty());  // the worker is held
  EXPECT_EQ(signals.load(), 0);
  gate.set_value();
  reference_gate.set_value();
  tracker.waitForSearch();
  reference.waitForSearch();
  EXPECT_EQ(signals.load(), kHeld);
  const std::vector<FrameResult> ready = tracker.takeReadyLateResults();
  EXPECT_TRUE(tracker.takeReadyLateResults().empty());  // taken once
  ASSERT_EQ(ready.size(), static_cast<size_t>(kHeld));

  const FrameResult next =
      tracker.update(observationsOf(kHeld), kHeld * kFramePeriod, kFirstId + kHeld);
  EXPECT_TRUE(tracker.takeLateResults().empty());
  const FrameResult reference_next =
      reference.update(observationsOf(kHeld), kHeld * kFramePeriod, kFirstId + kHeld);
  const std::vector<FrameResult> reference_late = reference.takeLateResults();
  ASSERT_EQ(reference_late.size(), static_cast<size_t>(kHeld));
  for (int i = 0; i < kHeld; ++i) {
    EXPECT_TRUE(ready[i].late);
    EXPECT_EQ(ready[i].frame_id, kFirstId + i);
    EXPECT_EQ(ready[i].status, reference_late[i].status) << "set " << i;
    EXPECT_LT(fingertipDifference(ready[i], reference_late[i]), 1e-9) << "set " << i;
  }
  ASSERT_TRUE(next.has_pose);
  ASSERT_TRUE(reference_next.has_pose);
  EXPECT_LT(fingertipDifference(next, reference_next), 1e-9);

  // Re-detections (every 3rd set) run on workers while the frame path has a pose: no signal.
  for (int frame = kHeld + 1; frame < kHeld + 10; ++frame) {
    EXPECT_TRUE(
        tracker.update(observationsOf(frame), frame * kFramePeriod, kFirstId + frame).has_pose);
    tracker.waitForSearch();
    EXPECT_TRUE(tracker.takeReadyLateResults().empty()) << "frame " << frame;
  }
  EXPECT_EQ(signals.load(), kHeld);
}
