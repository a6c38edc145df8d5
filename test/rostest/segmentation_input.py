#!/usr/bin/env python3
"""rostest node for the segmentation nodelet (cam0): learns the plate from grey frames, then a
skin-coloured square must come out as image Gaussians inside the square, stamped like the image;
malformed images (mono8, size not matching camera_info, empty) are logged and skipped, and good
images are still segmented afterwards."""
import sys
import threading
import unittest

import rospy
import rostest
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import CameraInfo, Image
from sag_hand_tracker.msg import SumOfGaussians

from camera_messages import pinhole_info

W, H = 160, 120


def make_info(stamp):
    return pinhole_info(stamp, "cam0_optical_frame", W, H)


def make_image(stamp, w=W, h=H, encoding="rgb8", square=False):
    img = Image()
    img.header.stamp = stamp
    img.header.frame_id = "cam0_optical_frame"
    img.width, img.height, img.encoding = w, h, encoding
    channels = 1 if encoding == "mono8" else 3
    img.step = w * channels
    data = bytearray([120] * (w * h * channels))
    if square and channels == 3:
        for y in range(40, 80):  # skin colour (R > G > B) square at x, y in [60, 100) x [40, 80)
            for x in range(60, 100):
                i = (y * w + x) * 3
                data[i:i + 3] = bytes([220, 160, 120])
    img.data = bytes(data)
    return img


class SegmentationInput(unittest.TestCase):
    def test_segmentation(self):
        self.sogs, self.warnings, lock = [], [], threading.Lock()

        def on_sog(msg):
            with lock:
                self.sogs.append(msg)

        def on_log(msg):
            if msg.level >= Log.WARN:
                with lock:
                    self.warnings.append(msg.msg)
        rospy.Subscriber("cam0/sog", SumOfGaussians, on_sog)
        rospy.Subscriber("/rosout", Log, on_log)
        img_pub = rospy.Publisher("cam0/image_raw", Image, queue_size=10)
        info_pub = rospy.Publisher("cam0/camera_info", CameraInfo, queue_size=10)
        deadline = rospy.Time.now() + rospy.Duration(20)
        while img_pub.get_num_connections() == 0 and rospy.Time.now() < deadline:
            rospy.sleep(0.1)  # the nodelet subscribes lazily, once we subscribe to sog
        self.assertGreater(img_pub.get_num_connections(), 0, "segmentation never subscribed")
        rospy.sleep(0.5)

        def send(image, info):
            img_pub.publish(image)
            info_pub.publish(info)
            rospy.sleep(0.1)

        stamp = lambda: rospy.Time.now()
        for _ in range(5):  # background (background_frames = 3 in the .test)
            t = stamp()
            send(make_image(t), make_info(t))
        good_stamps = []
        for _ in range(3):
            t = stamp()
            good_stamps.append(t)
            send(make_image(t, square=True), make_info(t))
        bad = []
        for _ in range(3):
            t = stamp(); bad.append(t)
            send(make_image(t, encoding="mono8"), make_info(t))
            t = stamp(); bad.append(t)
            send(make_image(t, w=80, h=60), make_info(t))  # size mismatch
            t = stamp(); bad.append(t)
            send(make_image(t, w=0, h=0), make_info(t))  # empty
        for _ in range(3):
            t = stamp()
            good_stamps.append(t)
            send(make_image(t, square=True), make_info(t))
        rospy.sleep(1.5)

        with lock:
            by_stamp = {m.header.stamp: m for m in self.sogs}
            for t in bad:
                self.assertNotIn(t, by_stamp, "a malformed image produced a SoG")
            got = [by_stamp[t] for t in good_stamps if t in by_stamp]
            self.assertGreaterEqual(len(got), 5, "good images not segmented (after bad ones)")
            for m in got:
                self.assertEqual(m.header.frame_id, "cam0_optical_frame")
                self.assertEqual((m.width, m.height), (W, H))
                self.assertGreater(len(m.gaussians), 0)
                for g in m.gaussians:  # only the square is foreground (one cell of slack)
                    self.assertTrue(56 <= g.x <= 104 and 36 <= g.y <= 84, (g.x, g.y))
            for expected in ["encoding 'mono8' not supported", "does not match camera_info",
                             "empty image"]:
                self.assertTrue(any(expected in w for w in self.warnings),
                                "no WARN containing '%s' in %s" % (expected, self.warnings))


if __name__ == "__main__":
    rospy.init_node("segmentation_input")
    rostest.rosrun("sag_hand_tracker", "segmentation_input", SegmentationInput, sys.argv)
