// The live tracker's grouping of N cameras' messages into sets by stamp.
#include <gtest/gtest.h>

#include <string>

#include "sag_hand_tracker/tracking/camera_set_synchronizer.h"

namespace sag_hand_tracker {
namespace {

using Sync = CameraSetSynchronizer<std::string>;
constexpr std::int64_t kSecond = 1000000000;

Sync makeSync(int cameras, double timeout = 0.5, double jump = 1.0,
              double tolerance = CameraSetSynchronizerParams().stamp_tolerance) {
  CameraSetSynchronizerParams params;
  params.num_cameras = cameras;
  params.camera_timeout = timeout;
  params.time_jump_threshold = jump;
  params.stamp_tolerance = tolerance;
  return Sync(params);
}

std::int64_t stamp(int frame) { return 100 * kSecond + frame * (kSecond / 25); }

TEST(CameraSetSynchronizer, ReleasesASetWhenEveryCameraDelivered) {
  Sync sync = makeSync(3);
  EXPECT_FALSE(sync.add(0, stamp(1), "a0", 0.0));
  EXPECT_FALSE(sync.add(2, stamp(1), "c0", 0.0));
  const auto set = sync.add(1, stamp(1), "b0", 0.01);
  ASSERT_TRUE(set);
  EXPECT_EQ(set->stamp_ns, stamp(1));
  EXPECT_EQ(set->count(), 3);
  EXPECT_EQ(*set->messages[1], "b0");
  EXPECT_EQ(sync.pendingCount(), 0u);
  EXPECT_EQ(sync.statistics().released_sets, 1);
}

// With stamp_tolerance 0, sets are made of identical stamps only.
TEST(CameraSetSynchronizer, OutOfOrderStampsAcrossCamerasStillPairUp) {
  Sync sync = makeSync(2, 0.5, 1.0, 0.0);
  EXPECT_FALSE(sync.add(0, stamp(1), "a1", 0.0));
  EXPECT_FALSE(sync.add(0, stamp(2), "a2", 0.0));
  EXPECT_FALSE(sync.add(1, stamp(1) + 1, "b1+1ns", 0.0));  // a different stamp: no pair
  const auto set = sync.add(1, stamp(2), "b2", 0.0);
  ASSERT_TRUE(set);
  EXPECT_EQ(set->stamp_ns, stamp(2));
  // The incomplete older sets (stamp 1 and stamp 1 + 1 ns) were overtaken and dropped.
  EXPECT_EQ(sync.statistics().dropped_sets, 2);
  EXPECT_EQ(sync.pendingCount(), 0u);
}

// Cameras that are not stamped together (free-running drivers): a message joins the nearest
// pending set within the stamp tolerance that lacks its camera, and the set keeps its first stamp;
// one camera's next frame (a frame period later) never joins, nor does a stamp beyond the
// tolerance.
TEST(CameraSetSynchronizer, StampsWithinTheToleranceMakeOneSet) {
  Sync sync = makeSync(3);  // the default tolerance, 5 ms
  const std::int64_t ms = kSecond / 1000;
  EXPECT_FALSE(sync.add(0, stamp(1), "a1", 0.0));
  EXPECT_FALSE(sync.add(1, stamp(1) + 4 * ms, "b1+4ms", 0.0));
  EXPECT_FALSE(sync.add(0, stamp(2), "a2", 0.0));
  EXPECT_FALSE(sync.add(1, stamp(2) - 3 * ms, "b2-3ms", 0.0));
  auto set = sync.add(2, stamp(1) + 2 * ms, "c1+2ms", 0.0);
  ASSERT_TRUE(set);
  EXPECT_EQ(set->stamp_ns, stamp(1));
  EXPECT_EQ(*set->messages[0], "a1");
  EXPECT_EQ(*set->messages[1], "b1+4ms");
  EXPECT_EQ(*set->messages[2], "c1+2ms");
  // Camera 2's next frame 6 ms off is beyond the tolerance: a set of its own, which then waits.
  EXPECT_FALSE(sync.add(2, stamp(2) + 6 * ms, "c2+6ms", 0.0));
  EXPECT_EQ(sync.pendingCount(), 2u);
  EXPECT_EQ(sync.statistics().tolerated_stamps, 3);
  // A second message of a camera within the tolerance of a set that has it starts a new set.
  Sync repeated = makeSync(2);
  EXPECT_FALSE(repeated.add(0, stamp(1), "a1", 0.0));
  EXPECT_FALSE(repeated.add(0, stamp(1) + ms, "a1+1ms", 0.0));
  EXPECT_EQ(repeated.pendingCount(), 2u);
  set = repeated.add(1, stamp(1) + 2 * ms, "b", 0.0);  // nearest without camera 1: a1+1ms
  ASSERT_TRUE(set);
  EXPECT_EQ(set->stamp_ns, stamp(1) + ms);
  EXPECT_EQ(*set->messages[0], "a1+1ms");
}

TEST(CameraSetSynchronizer, ARepeatedStampOfOneCameraReplacesItsMessage) {
  Sync sync = makeSync(2);
  EXPECT_FALSE(sync.add(0, stamp(1), "first", 0.0));
  EXPECT_FALSE(sync.add(0, stamp(1), "second", 0.0));  // still waiting for camera 1
  const auto set = sync.add(1, stamp(1), "b", 0.0);
  ASSERT_TRUE(set);
  EXPECT_EQ(*set->messages[0], "second");
  EXPECT_EQ(set->count(), 2);
}

TEST(CameraSetSynchronizer, LateMessagesOfAReleasedSetAreIgnoredAndReported) {
  Sync sync = makeSync(2);
  sync.add(0, stamp(2), "a2", 0.0);
  ASSERT_TRUE(sync.add(1, stamp(2), "b2", 0.0));
  EXPECT_FALSE(sync.add(0, stamp(1), "a1 late", 0.0));
  EXPECT_FALSE(sync.add(1, stamp(2), "b2 again", 0.0));  // same stamp as the released set
  EXPECT_EQ(sync.statistics().late_messages, 2);
  EXPECT_EQ(sync.pendingCount(), 0u);
  const auto events = sync.takeEvents();
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].kind, SyncEvent::Kind::kLate);
  EXPECT_EQ(events[0].camera, 0);
  EXPECT_NEAR(events[0].seconds, 0.04, 1e-9);
  EXPECT_TRUE(sync.takeEvents().empty());
}

TEST(CameraSetSynchronizer, AMissingCameraTimesOutAndIsNoLongerWaitedFor) {
  Sync sync = makeSync(3, 0.5);
  sync.add(0, stamp(1), "a1", 10.0);
  sync.add(1, stamp(1), "b1", 10.1);
  EXPECT_TRUE(sync.poll(10.4).empty());  // not yet timed out
  const auto released = sync.poll(10.5);
  ASSERT_EQ(released.size(), 1u);
  EXPECT_EQ(released[0].count(), 2);
  EXPECT_FALSE(released[0].messages[2]);
  EXPECT_TRUE(sync.isMissing(2));
  EXPECT_EQ(sync.missingCount(), 1);
  auto events = sync.takeEvents();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, SyncEvent::Kind::kCameraMissing);
  EXPECT_EQ(events[0].camera, 2);
  // The next set is complete with the two cameras that still deliver.
  sync.add(0, stamp(2), "a2", 10.6);
  const auto set = sync.add(1, stamp(2), "b2", 10.6);
  ASSERT_TRUE(set);
  EXPECT_EQ(set->count(), 2);
  // The camera comes back: it is waited for again.
  EXPECT_FALSE(sync.add(2, stamp(3), "c3", 10.7));
  EXPECT_FALSE(sync.isMissing(2));
  events = sync.takeEvents();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, SyncEvent::Kind::kCameraBack);
  sync.add(0, stamp(3), "a3", 10.7);
  const auto back = sync.add(1, stamp(3), "b3", 10.7);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->count(), 3);
}

TEST(CameraSetSynchronizer, TimedOutSetsAreReleasedOldestFirst) {
  Sync sync = makeSync(2, 0.2);
  sync.add(0, stamp(1), "a1", 0.0);
  sync.add(0, stamp(2), "a2", 0.05);
  sync.add(0, stamp(3), "a3", 0.3);
  const auto released = sync.poll(0.26);
  // Stamps 1 and 2 timed out; camera 1 is then missing, which completes stamp 3 at once.
  ASSERT_EQ(released.size(), 3u);
  EXPECT_EQ(released[0].stamp_ns, stamp(1));
  EXPECT_EQ(released[1].stamp_ns, stamp(2));
  EXPECT_EQ(released[2].stamp_ns, stamp(3));
  EXPECT_EQ(sync.pendingCount(), 0u);
  const auto set = sync.add(0, stamp(4), "a4", 0.31);
  ASSERT_TRUE(set);
  EXPECT_EQ(set->stamp_ns, stamp(4));
  EXPECT_EQ(sync.statistics().dropped_sets, 0);
}

TEST(CameraSetSynchronizer, StampsJumpingBackResetEverything) {
  Sync sync = makeSync(2, 0.5, 1.0);
  sync.add(0, stamp(100), "a", 0.0);
  ASSERT_TRUE(sync.add(1, stamp(100), "b", 0.0));
  sync.add(0, stamp(101), "pending", 0.0);
  // A bag loop: back by 4 s, more than the threshold.
  EXPECT_FALSE(sync.add(0, stamp(0), "a0", 0.1));
  EXPECT_EQ(sync.statistics().resets, 1);
  EXPECT_EQ(sync.pendingCount(), 1u);  // only the new message; the old pending set is gone
  const auto events = sync.takeEvents();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, SyncEvent::Kind::kTimeJumpBack);
  EXPECT_NEAR(events[0].seconds, 4.0, 1e-9);
  const auto set = sync.add(1, stamp(0), "b0", 0.1);
  ASSERT_TRUE(set);
  EXPECT_EQ(set->stamp_ns, stamp(0));
}

TEST(CameraSetSynchronizer, TheClockJumpingBackResetsButForwardDoesNot) {
  Sync sync = makeSync(2, 0.5, 1.0);
  EXPECT_FALSE(sync.checkClock(100.0));
  sync.add(0, stamp(1), "a", 0.0);
  EXPECT_FALSE(sync.checkClock(99.5));    // back by less than the threshold
  EXPECT_FALSE(sync.checkClock(5000.0));  // forward: fine
  EXPECT_EQ(sync.pendingCount(), 1u);
  EXPECT_TRUE(sync.checkClock(10.0));
  EXPECT_EQ(sync.pendingCount(), 0u);
  EXPECT_EQ(sync.statistics().resets, 1);
}

TEST(CameraSetSynchronizer, RejectsACameraIndexOutsideTheRange) {
  Sync sync = makeSync(2);
  EXPECT_THROW(sync.add(2, stamp(1), "x", 0.0), std::out_of_range);
  EXPECT_THROW(sync.add(-1, stamp(1), "x", 0.0), std::out_of_range);
  EXPECT_EQ(sync.pendingCount(), 0u);
}

}  // namespace
}  // namespace sag_hand_tracker
