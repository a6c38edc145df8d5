#!/usr/bin/env python3
"""rostest node for the segmentation nodelets' skin gate from the user's colours: images with a
square of the user's skin and a square of wood (both pass the generic skin gate) go to cam0
(skin_model: a calibrated model), cam1 (none) and cam2 (a missing file). cam0's image Gaussians
lie on the skin square only, cam1's and cam2's on both, and cam2's missing file is said with its
name. Then a gate comes on cam1/skin_gate (as the tracker sends it) and a bad one (NaN) on
cam2/skin_gate: cam1 drops the wood from then on, cam2 says why it ignored its gate and keeps
the wood."""
import sys
import threading
import unittest

import rospy
import rostest
from rosgraph_msgs.msg import Log
from sensor_msgs.msg import CameraInfo, Image
from sag_hand_tracker.msg import SkinGate, SumOfGaussians

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
        def send_images(count):
            stamps = []
            for _ in range(count):
                t = rospy.Time.now()
                stamps.append(t)
                for c in cams:
                    pubs[c][0].publish(make_image(t, c + "_optical_frame"))
                    pubs[c][1].publish(pinhole_info(t, c + "_optical_frame", W, H))
                rospy.sleep(0.2)
            rospy.sleep(1.5)
            return stamps

        before = send_images(4)
        # The gates, latched as the tracker publishes them: the studio hand's (test/data's model:
        # hue 7.5..39.1, saturation 0.15..0.56) for cam1, a broken one for cam2.
        gate = SkinGate(source="test", hue_min_deg=7.5, hue_max_deg=39.1, saturation_min=0.15,
                        saturation_max=0.56, value_min=0.24)
        bad = SkinGate(source="test", hue_min_deg=7.5, hue_max_deg=39.1, saturation_min=0.15,
                       saturation_max=0.56, value_min=float("nan"))
        gate_pubs = [rospy.Publisher(c + "/skin_gate", SkinGate, queue_size=1, latch=True)
                     for c in ("cam1", "cam2")]
        gate_pubs[0].publish(gate)
        gate_pubs[1].publish(bad)
        rospy.sleep(1.0)
        after = send_images(3)

        def on_square(g, columns):  # one 4-pixel cell of slack
            return columns[0] - 4 <= g.x <= columns[1] + 4 and 36 <= g.y <= 84

        with lock:
            for c in cams:
                for stamps, wood_kept in ((before, c != "cam0"), (after, c == "cam2")):
                    got = [m for m in self.sogs[c] if m.header.stamp in stamps]
                    self.assertGreaterEqual(len(got), 2, c + ": images not segmented")
                    for m in got:
                        self.assertTrue(all(on_square(g, SKIN_X) or on_square(g, WOOD_X)
                                            for g in m.gaussians), c)
                        self.assertTrue(any(on_square(g, SKIN_X) for g in m.gaussians),
                                        c + ": the skin square is not foreground")
                        wood = any(on_square(g, WOOD_X) for g in m.gaussians)
                        self.assertEqual(wood, wood_kept,
                                         "%s, %s the gate message: wood %s" %
                                         (c, "before" if stamps is before else "after",
                                          "kept" if wood else "dropped"))
            # Said at start-up (before this node listened) and again with the first image.
            warnings = [text for level, text in self.logs if level >= Log.WARN]
            self.assertTrue(any("generic skin gate" in w and "/nonexistent/my_hand.yaml" in w
                                and "does not exist" in w for w in warnings), warnings)
            self.assertTrue(any("skin_gate message ignored" in w and "not finite" in w
                                for w in warnings), warnings)
            infos = [text for level, text in self.logs if level == Log.INFO]
            self.assertTrue(any("skin gate from the tracker (test)" in i for i in infos), infos)
            self.assertTrue(any("the skin gate from" in i and "default_fitted.yaml" in i
                                for i in infos), infos)


if __name__ == "__main__":
    rospy.init_node("segmentation_skin_model")
    rostest.rosrun("sag_hand_tracker", "segmentation_skin_model", SegmentationSkinModel,
                   sys.argv)
