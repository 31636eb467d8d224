"""Detectors registered from outside the node run through the real detector node: a detector
started from a rectangle gets it through the select_region service; methods that are not seeded
refuse it with a reason."""

from __future__ import annotations

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

import region_detector  # noqa: E402
from node_harness import NodeHarness  # noqa: E402
from sensor_msgs.msg import Image  # noqa: E402

from tracker_detect.detector_node import DetectorNode  # noqa: E402
from tracker_detect.detectors import DETECTORS  # noqa: E402
from tracker_msgs.msg import BlobArray  # noqa: E402
from tracker_msgs.srv import SelectRegion  # noqa: E402
from tracker_msgs_py.codec import array_to_image, image_qos, ns_to_stamp, rect_to_msg  # noqa: E402
from tracker_msgs_py.geometry import Rect  # noqa: E402

pytestmark = pytest.mark.ros
NS = 100_000_000


def harness(method: str) -> NodeHarness:
    return NodeHarness(
        DetectorNode,
        inputs={"camera/image_raw": (Image, image_qos(True))},
        outputs={"detections": (BlobArray, 50)},
        method=method,
        pose_source="none",
        reliable_images=True,
    )


def send_image(h: NodeHarness, k: int) -> BlobArray:
    pixels = np.full((120, 160, 3), 100, np.uint8)
    count = len(h.received["detections"])
    h.publish("camera/image_raw", array_to_image(pixels, "bgr8", ns_to_stamp(k * NS), "camera"))
    h.spin_until(lambda: len(h.received["detections"]) > count)
    return h.received["detections"][-1]


def select_region(h: NodeHarness, rect: Rect) -> SelectRegion.Response:
    client = h.peer.create_client(SelectRegion, "detector/select_region")
    h.spin_until(lambda: client.service_is_ready())
    future = client.call_async(SelectRegion.Request(region=rect_to_msg(rect)))
    h.spin_until(future.done)
    return future.result()


def test_a_seeded_detector_starts_from_the_selected_region():
    DETECTORS.register(region_detector.METHOD, replace=True)
    h = harness("region_test")
    try:
        assert send_image(h, 1).blobs == []
        response = select_region(h, Rect(20.0, 30.0, 40.0, 20.0))
        assert response.success, response.message
        detections = send_image(h, 2)
        assert detections.header.stamp == ns_to_stamp(2 * NS) and detections.target_present
        [blob] = detections.blobs
        assert (blob.centroid_x, blob.centroid_y, blob.area) == (40.0, 40.0, 800)
        assert not select_region(h, Rect(0.0, 0.0, 0.0, 5.0)).success  # the detector's reason
    finally:
        h.close()
        DETECTORS.unregister(region_detector.METHOD.name)


def test_a_detector_not_seeded_from_a_region_refuses_it_with_a_reason():
    h = harness("ssim")
    try:
        send_image(h, 1)
        response = select_region(h, Rect(20.0, 30.0, 40.0, 20.0))
        assert not response.success and "not started from a region" in response.message
    finally:
        h.close()
