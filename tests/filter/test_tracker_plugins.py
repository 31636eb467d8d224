"""A tracker that needs the colour image, registered from outside the node, runs through the real
tracker node end to end: the node subscribes to the image and the camera window because the
tracker needs them, pairs them with the detections by stamp, and publishes the tracker's own state
layout. A frame whose image never comes is still answered once."""

from __future__ import annotations

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

import colour_tracker  # noqa: E402
from node_harness import NodeHarness  # noqa: E402
from sensor_msgs.msg import Image  # noqa: E402

from tracker_filter.tracker_node import TrackerNode  # noqa: E402
from tracker_filter.trackers import TRACKERS  # noqa: E402
from tracker_msgs.msg import BlobArray, PtzState, TrackArray  # noqa: E402
from tracker_msgs_py.codec import array_to_image, image_qos, ns_to_stamp, rect_to_msg  # noqa: E402
from tracker_msgs_py.geometry import Rect  # noqa: E402

pytestmark = pytest.mark.ros
NS = 100_000_000  # 10 frames/s
WINDOW = Rect(100.0, 50.0, 320.0, 240.0)  # scene px the camera sees; images are 160x120: 2 px/px


@pytest.fixture
def harness():
    TRACKERS.register(colour_tracker.METHOD, replace=True)
    h = NodeHarness(
        TrackerNode,
        inputs={
            "detections": (BlobArray, 50),
            "ptz/state": (PtzState, 50),
            "camera/image_raw": (Image, image_qos(False)),
        },
        outputs={"tracks": (TrackArray, 50)},
        method="red_blob_test",
        max_misses=3,
    )
    yield h
    h.close()
    TRACKERS.unregister(colour_tracker.METHOD.name)


def camera_image(stamp_ns: int, red_at: tuple[int, int] | None) -> Image:
    pixels = np.full((120, 160, 3), 90, np.uint8)
    if red_at is not None:
        u, v = red_at
        pixels[v : v + 10, u : u + 20] = (0, 0, 255)  # BGR red, 20x10 camera px
    return array_to_image(pixels, "bgr8", ns_to_stamp(stamp_ns), "camera")


def send_frame(h: NodeHarness, stamp_ns: int, red_at, with_image=True) -> None:
    stamp = ns_to_stamp(stamp_ns)
    if with_image:
        h.publish("camera/image_raw", camera_image(stamp_ns, red_at))
    state = PtzState(window=rect_to_msg(WINDOW))
    state.header.stamp, state.header.frame_id = stamp, "scene"
    h.publish("ptz/state", state)
    detections = BlobArray(target_present=False)  # the tracker ignores them
    detections.header.stamp, detections.header.frame_id = stamp, "scene"
    h.publish("detections", detections)


def test_a_tracker_that_needs_the_image_runs_through_the_real_node(harness):
    h = harness
    assert h.node.count_subscribers("camera/image_raw") == 1  # subscribed because it is needed
    for k in range(5):
        send_frame(h, (k + 1) * NS, red_at=(40 + 4 * k, 30))
        h.spin_until(lambda k=k: len(h.received["tracks"]) == k + 1)
    last = h.received["tracks"][-1]
    assert [t.id for t in last.tracks] == [1]
    track = last.tracks[0]
    # red box: camera px (56, 30) 20x10 -> scene (100 + 2*56, 50 + 2*30) 40x20, centre +20, +10
    assert track.state_layout == "x y w h"
    assert (track.x, track.y) == pytest.approx((232.0, 120.0))
    assert list(track.state) == pytest.approx([232.0, 120.0, 40.0, 20.0])
    assert (track.vx, track.vy) == (0.0, 0.0)  # the layout has no velocity
    assert (track.bbox.x, track.bbox.width, track.bbox.height) == pytest.approx((212.0, 40.0, 20.0))
    assert last.header.stamp == ns_to_stamp(5 * NS) and last.header.frame_id == "scene"


def test_a_frame_whose_image_never_comes_is_answered_as_a_miss(harness):
    h = harness
    send_frame(h, 1 * NS, red_at=(40, 30))
    h.spin_until(lambda: len(h.received["tracks"]) == 1)
    send_frame(h, 2 * NS, red_at=None, with_image=False)  # lost in transport
    h.spin_for(0.3)
    assert len(h.received["tracks"]) == 1  # still waiting: the image may come
    send_frame(h, 3 * NS, red_at=(44, 30))  # a newer image: frame 2's will never come
    h.spin_until(lambda: len(h.received["tracks"]) == 3)
    second, third = h.received["tracks"][1:]
    assert second.header.stamp == ns_to_stamp(2 * NS)
    assert [t.consecutive_misses for t in second.tracks] == [1]
    assert [t.consecutive_misses for t in third.tracks] == [0]
