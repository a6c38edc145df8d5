#!/usr/bin/env python3
"""rostest node for the segmentation nodelets' skin_model parameter: images with a square of the
user's skin and a square of wood (both pass the generic skin gate) go to cam0 (skin_model: a
calibrated model), cam1 (none) and cam2 (a missing file). cam0's image Gaussians lie on the skin
square only; cam1's and cam2's on both; cam2's missing file is an ERROR that names it."""
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
SKIN = (200, 140, 110)  # the studio hand's skin in light: hue 20 deg, saturation 0.45
WOOD = (160, 100, 50)   # passes the generic gate; saturation 0.69, above the hand's
SKIN_X, WOOD_X = (20, 60), (100, 140)  # columns of the squares, rows 40..80


def make_image(stamp, frame):
    img = Image()
    img.header.stamp = stamp
    img.header.frame_id = frame
    img.width, img.height, img.encoding = W, H, "rgb8"
    img.step = W * 3
    data = bytearray([90, 110, 140] * (W * H))  # a blue-grey desk: no skin
    for (x0, x1), colour in ((SKIN_X, SKIN), (WOOD_X, WOOD)):
        for y in range(40, 80):
            for x in range(x0, x1):
                i = (y * W + x) * 3
                data[i:i + 3] = bytes(colour)
    img.data = bytes(data)
    return img


class SegmentationSkinModel(unittest.TestCase):
    def test_skin_model(self):
        cams = ["cam0", "cam1", "cam2"]
        self.sogs = {c: [] for c in cams}
        self.logs = []
        lock = threading.Lock()

        def on_log(msg):
            with lock:
                self.logs.append((msg.level, msg.msg))

        rospy.Subscriber("/rosout", Log, on_log)
        pubs = {}
        for c in cams:
            rospy.Subscriber(c + "/sog", SumOfGaussians,
                             lambda msg, c=c: self.sogs[c].append(msg))
            pubs[c] = (rospy.Publisher(c + "/image_raw", Image, queue_size=10),
                       rospy.Publisher(c + "/camera_info", CameraInfo, queue_size=10))
        deadline = rospy.Time.now() + rospy.Duration(20)
        while (any(p[0].get_num_connections() == 0 for p in pubs.values())
               and rospy.Time.now() < deadline):
            rospy.sleep(0.1)  # the nodelets subscribe lazily, once we subscribe to sog
        for c in cams:
            self.assertGreater(pubs[c][0].get_num_connections(), 0, c + " never subscribed")
        rospy.sleep(0.5)
        for _ in range(4):
            t = rospy.Time.now()
            for c in cams:
                pubs[c][0].publish(make_image(t, c + "_optical_frame"))
                pubs[c][1].publish(pinhole_info(t, c + "_optical_frame", W, H))
            rospy.sleep(0.2)
        rospy.sleep(1.5)

        def on_square(g, columns):  # one 4-pixel cell of slack
            return columns[0] - 4 <= g.x <= columns[1] + 4 and 36 <= g.y <= 84

        with lock:
            for c in cams:
                self.assertGreaterEqual(len(self.sogs[c]), 2, c + ": images not segmented")
                for m in self.sogs[c]:
                    self.assertTrue(all(on_square(g, SKIN_X) or on_square(g, WOOD_X)
                                        for g in m.gaussians), c)
                    self.assertTrue(any(on_square(g, SKIN_X) for g in m.gaussians),
                                    c + ": the skin square is not foreground")
                    wood = any(on_square(g, WOOD_X) for g in m.gaussians)
                    self.assertEqual(wood, c != "cam0",
                                     c + (": the wood passed the user's gate" if c == "cam0"
                                          else ": the generic gate dropped the wood"))
            # Said at start-up (before this node listened) and again with the first image.
            warnings = [text for level, text in self.logs if level >= Log.WARN]
            self.assertTrue(any("generic skin gate" in w and "/nonexistent/my_hand.yaml" in w
                                and "does not exist" in w for w in warnings), warnings)
            infos = [text for level, text in self.logs if level == Log.INFO]
            self.assertTrue(any("the skin gate from" in i and "default_fitted.yaml" in i
                                for i in infos), infos)


if __name__ == "__main__":
    rospy.init_node("segmentation_skin_model")
    rostest.rosrun("sag_hand_tracker", "segmentation_skin_model", SegmentationSkinModel,
                   sys.argv)
