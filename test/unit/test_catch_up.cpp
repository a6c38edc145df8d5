// The catch-up of the asynchronous search (issue 12, TrackerParams::catch_up_seconds): the sets
// that arrive without a pose while a search runs get their poses afterwards, in order, as the
// synchronous search would have given them. The searches are held on a gate
// (HandTracker::holdSearchesUntil), so that the tests decide how many sets arrive meanwhile.
#include <gtest/gtest.h>

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
  HandTracker tracker(model, params);
  std::promise<void> gate;
  tracker.holdSearchesUntil(gate.get_future().share());
  TrackerParams synchronous_params = params;
  synchronous_params.asynchronous_search = false;
  HandTracker synchronous(model, synchronous_params);

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

// A lost track: the hand jumps away, the re-detection search is held for four sets; they get
// their poses afterwards (the first one a restart), close to the truth and to the poses of a
// synchronous tracker (which restarts on the jump's set itself, so they are not identical).
TEST(TrackerCatchUp, EverySetDuringARestartSearchGetsItsPoseAfterwards) {
  const HandModel model = loadHandModel(modelPath("sag"));
  const std::vector<Camera> cameras = fiveCameraRig();
  TrackerParams params;
  params.asynchronous_search = true;
  params.redetect_interval = 0;  // only the restart searches
  HandTracker tracker(model, params);
  std::promise<void> gate;
  TrackerParams synchronous_params = params;
  synchronous_params.asynchronous_search = false;
  HandTracker synchronous(model, synchronous_params);

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
  // is plausible, else late), reported in frame order; the first late one restarted the track.
  ASSERT_EQ(run.order.size(), static_cast<size_t>(kFrames));
  bool restarted = false;
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
    if (result.late && !restarted) {
      restarted = true;
      EXPECT_TRUE(result.restarted) << "frame " << frame;
      EXPECT_EQ(result.status, TrackStatus::kStarted) << "frame " << frame;
    } else {
      EXPECT_EQ(result.status, TrackStatus::kTracking) << "frame " << frame;
    }
    EXPECT_LT(meanFingertipError(result.fingertips, fingertips(model, truths[id])), 0.025)
        << "frame " << frame;
    ASSERT_TRUE(expected[id].has_pose) << "frame " << frame;
    EXPECT_LT(fingertipDifference(result, expected[id]), 0.005) << "frame " << frame;
  }
  EXPECT_TRUE(restarted);
}

// The bound: with catch_up_seconds 0.1 at 25 fps only the sets of the last 0.1 s before the
// search finished are kept; the older ones stay as they were reported (waiting, no pose). The
// search, launched for a set that was not kept, is refined on the oldest kept set.
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

  // catch_up_seconds 0: nothing is kept, the finished search starts the track on a later set.
  params.catch_up_seconds = 0.0;
  HandTracker without(model, params);
  std::promise<void> second_gate;
  without.holdSearchesUntil(second_gate.get_future().share());
  for (int frame = 0; frame < 3; ++frame) {
    without.update(modelObservations(model, movingHand(model, frame), cameras, 3.0),
                   frame * kFramePeriod, frame);
  }
  EXPECT_EQ(without.keptFrames(), 0);
  second_gate.set_value();
  without.waitForSearch();
  const FrameResult started = without.update(
      modelObservations(model, movingHand(model, 3), cameras, 3.0), 3 * kFramePeriod, 3);
  EXPECT_TRUE(started.has_pose);
  EXPECT_EQ(started.status, TrackStatus::kStarted);
  EXPECT_TRUE(without.takeLateResults().empty());
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

// A set that needs a new search during the catch-up is kept again with the ones after it: the
// search for an empty set (no camera sees the hand) finds nothing, so the next kept set launches
// its own; the sets with the hand get their poses once the search of the first of them is done.
TEST(TrackerCatchUp, ASetThatNeedsANewSearchIsKeptAgain) {
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
  // Set 0's search found nothing: set 0 stays without a pose, set 1 launches a search of its own
  // and is kept with the rest.
  EXPECT_FALSE(update(5).has_pose);
  EXPECT_TRUE(tracker.takeLateResults().empty());
  EXPECT_EQ(tracker.keptFrames(), 5);  // sets 1..5
  tracker.waitForSearch();
  // Set 1 (empty) finds nothing either; set 2, the first with the hand, launches its own.
  EXPECT_FALSE(update(6).has_pose);
  EXPECT_TRUE(tracker.takeLateResults().empty());
  EXPECT_EQ(tracker.keptFrames(), 5);  // sets 2..6
  tracker.waitForSearch();
  const FrameResult result = update(7);
  ASSERT_TRUE(result.has_pose);
  EXPECT_EQ(result.status, TrackStatus::kTracking);
  const std::vector<FrameResult> late = tracker.takeLateResults();
  ASSERT_EQ(late.size(), 5u);
  for (int i = 0; i < 5; ++i) {
    const int frame = kFirstHand + i;
    EXPECT_EQ(late[i].frame_id, kFirstId + frame);
    EXPECT_TRUE(late[i].late);
    EXPECT_EQ(late[i].status, i == 0 ? TrackStatus::kStarted : TrackStatus::kTracking);
    EXPECT_LT(meanFingertipError(late[i].fingertips, fingertips(model, movingHand(model, frame))),
              0.02)
        << "frame " << frame;
  }
  EXPECT_EQ(tracker.keptFrames(), 0);
  EXPECT_FALSE(tracker.searching());
}
