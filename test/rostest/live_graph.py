#!/usr/bin/env python3
"""rostest node for live.launch: the driver (on image folders), the segmentation nodelets and the
tracker are wired end to end. Checks, over `duration` seconds: every camera publishes image_raw;
the tracker publishes a status for the camera sets, stamped with the images' stamp (one stamp per
set, carried from the driver through segmentation to the tracker); all num_cameras cameras reach
the tracker; the rig's extrinsics are on /tf_static."""
import sys
import threading
import unittest

import rospy
import rostest
from sensor_msgs.msg import Image
from tf2_msgs.msg import TFMessage
from sag_hand_tracker.msg import TrackingStatus


class LiveGraph(unittest.TestCase):
    def test_live_graph(self):
        duration = rospy.get_param("~duration", 15.0)
        num_cameras = rospy.get_param("~num_cameras", 5)
        root_frame = rospy.get_param("~root_frame", "world")
        min_status = rospy.get_param("~min_status", 20)
        lock = threading.Lock()
        stamps = {i: set() for i in range(num_cameras)}
        statuses, static_frames = [], {}

        def on_image(msg, camera):
            with lock:
                stamps[camera].add(msg.header.stamp)

        def on_status(msg):
            with lock:
                statuses.append(msg)

        def on_tf_static(msg):
            with lock:
                for t in msg.transforms:
                    static_frames[t.child_frame_id] = t.header.frame_id

        subs = [rospy.Subscriber("/cam%d/image_raw" % i, Image, on_image, i, queue_size=50)
                for i in range(num_cameras)]
        subs.append(rospy.Subscriber("/status", TrackingStatus, on_status, queue_size=50))
        subs.append(rospy.Subscriber("/tf_static", TFMessage, on_tf_static, queue_size=10))
        rospy.sleep(duration)
        for sub in subs:
            sub.unregister()

        with lock:
            for i in range(num_cameras):
                self.assertGreater(len(stamps[i]), 10, "cam%d published too few images" % i)
                self.assertEqual(static_frames.get("cam%d_optical_frame" % i), root_frame,
                                 "no static tf %s -> cam%d_optical_frame" % (root_frame, i))
            # The sets whose images every image subscription saw (they connect one by one).
            first = max(min(stamps[i]) for i in range(num_cameras))
            last = min(max(stamps[i]) for i in range(num_cameras))
            statuses = [s for s in statuses if first <= s.header.stamp <= last]
            self.assertGreaterEqual(len(statuses), min_status, "the tracker processed too few sets")
            for status in statuses:
                self.assertEqual(status.header.frame_id, root_frame)
                self.assertEqual(status.expected_cameras, num_cameras)
                for i in range(num_cameras):
                    self.assertIn(status.header.stamp, stamps[i],
                                  "status stamp not an image stamp of cam%d" % i)
            # Once the graph has settled, every camera's SoG reaches the tracker.
            settled = statuses[len(statuses) // 2:]
            full = [s for s in settled if s.num_cameras == num_cameras]
            self.assertGreaterEqual(len(full), len(settled) // 2,
                                    "cameras per set: %s" % [s.num_cameras for s in settled])


if __name__ == "__main__":
    rospy.init_node("live_graph_checker")
    rostest.rosrun("sag_hand_tracker", "live_graph", LiveGraph, sys.argv)
