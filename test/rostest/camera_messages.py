"""sensor_msgs for the rostest checker nodes: a camera_info of a plain pinhole camera."""
from sensor_msgs.msg import CameraInfo


def pinhole_info(stamp, frame_id, w, h, f=150.0):
    """A camera_info of w x h pixels, focal length f, principal point at the image centre, no
    distortion (plumb_bob with zeros), identity R."""
    info = CameraInfo()
    info.header.stamp = stamp
    info.header.frame_id = frame_id
    info.width, info.height = w, h
    info.distortion_model = "plumb_bob"
    info.D = [0.0] * 5
    info.K = [f, 0, w / 2.0, 0, f, h / 2.0, 0, 0, 1]
    info.R = [1, 0, 0, 0, 1, 0, 0, 0, 1]
    info.P = [f, 0, w / 2.0, 0, 0, f, h / 2.0, 0, 0, 0, 1, 0]
    return info
