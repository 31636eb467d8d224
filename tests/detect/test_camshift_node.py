"""The camshift method through the real detector node: started by the `initial_region` parameter,
handed over from another tracker's locked target, guided by its own tracker's target, with the
oriented box in the Blob message."""

from __future__ import annotations

import math

import pytest

rclpy = pytest.importorskip("rclpy")

from colour_scene import scene_with_target, target_position, true_box  # noqa: E402
from node_harness import NodeHarness  # noqa: E402
from sensor_msgs.msg import Image  # noqa: E402

from tracker_detect.detector_node import DetectorNode  # noqa: E402
from tracker_msgs.msg import BlobArray, Target, Track  # noqa: E402
from tracker_msgs_py.codec import (  # noqa: E402
    array_to_image,
    image_qos,
    msg_to_rect,
    ns_to_stamp,
    rect_to_msg,
)
from tracker_msgs_py.geometry import Rect  # noqa: E402

pytestmark = pytest.mark.ros
NS = 50_000_000


def harness(**params) -> NodeHarness:
    return NodeHarness(
        DetectorNode,
        inputs={
            "camera/image_raw": (Image, image_qos(True)),
            "target": (Target, 10),
            "handover_target": (Target, 10),
        },
        outputs={"detections": (BlobArray, 50)},
        method="camshift",
        pose_source="none",
        reliable_images=True,
        **params,
    )


def send(h: NodeHarness, k: int, **scene) -> BlobArray:
    count = len(h.received["detections"])
    image = array_to_image(scene_with_target(k, **scene), "bgr8", ns_to_stamp(k * NS), "camera")
    h.publish("camera/image_raw", image)
    h.spin_until(lambda: len(h.received["detections"]) > count)
    return h.received["detections"][-1]


def target_msg(
    k: int, box: Rect, status: int = Track.STATUS_CONFIRMED, vx: float = 0.0, hits: int = 10
) -> Target:
    msg = Target(locked=True)
    msg.header.stamp = ns_to_stamp(k * NS)
    msg.header.frame_id = "scene"
    cx, cy = box.center
    msg.track = Track(id=7, status=status, x=cx, y=cy, vx=vx, bbox=rect_to_msg(box), hits=hits)
    return msg


def publish_and_settle(h: NodeHarness, topic: str, msg: Target) -> None:
    h.publish(topic, msg)
    h.spin_for(0.2)


def test_started_by_the_initial_region_parameter_with_oriented_boxes():
    start = true_box(*target_position(0))
    h = harness(initial_region=[start.x, start.y, start.width, start.height])
    try:
        for k in range(0, 10):
            [blob] = send(h, k).blobs
            assert msg_to_rect(blob.bbox).iou(true_box(*target_position(k))) >= 0.5
            assert blob.oriented_width > 0 and blob.oriented_height > 0
            assert math.isfinite(blob.angle) and 0.0 < blob.score <= 1.0
    finally:
        h.close()


def test_handed_over_from_a_measured_target_but_not_from_a_coasting_or_young_one():
    h = harness()
    try:
        assert send(h, 0).blobs == []
        box0 = true_box(*target_position(0))
        publish_and_settle(h, "handover_target", target_msg(0, box0, Track.STATUS_COASTING))
        assert send(h, 1).blobs == [], "started from a coasting prediction"
        box1 = true_box(*target_position(1))
        publish_and_settle(h, "handover_target", target_msg(1, box1, hits=2))
        assert send(h, 2).blobs == [], "started from a track measured in 2 frames (of 5 needed)"
        box2 = true_box(*target_position(2))
        publish_and_settle(h, "handover_target", target_msg(2, box2))
        assert send(h, 3).blobs, "not started from a measured target"
        for k in range(4, 8):
            [blob] = send(h, k).blobs
            assert msg_to_rect(blob.bbox).iou(true_box(*target_position(k))) >= 0.5
    finally:
        h.close()


def first_frame_after_a_jump(guidance: Target | None) -> list:
    """Blobs of the frame where the target jumps beyond the search region (one harness at a
    time: two on one domain would hear each other's images)."""
    start = true_box(*target_position(0))
    h = harness(initial_region=[start.x, start.y, start.width, start.height])
    try:
        assert send(h, 0).blobs
        if guidance is not None:
            publish_and_settle(h, "target", guidance)
        return list(send(h, 1, position=JUMP).blobs)
    finally:
        h.close()


JUMP = (300.0, 120.0)


def test_the_target_guides_the_search_past_a_jump():
    assert first_frame_after_a_jump(None) == []
    # the tracker saw the target moving fast towards the jump; it predicts it there at frame 1
    start = true_box(*target_position(0))
    velocity = (JUMP[0] - start.center[0]) / (NS / 1e9)
    moving = target_msg(0, Rect.from_center(start.center[0], JUMP[1], 28, 60), vx=velocity)
    [blob] = first_frame_after_a_jump(moving)
    assert msg_to_rect(blob.bbox).iou(true_box(*JUMP)) >= 0.5


def test_lockstep_targets_hold_each_image_for_its_handover_and_the_previous_guidance():
    """With lockstep_targets an image is answered only once the hand-over target of its stamp and
    the own tracker's target of the image before have come, so what CamShift does with an image
    never depends on which message the transport delivered first; the hand-over starts tracking on
    the very image it was measured in."""
    h = harness(lockstep_targets=True, target_timeout=5.0)
    try:
        image = array_to_image(scene_with_target(0), "bgr8", ns_to_stamp(0), "camera")
        h.publish("camera/image_raw", image)
        h.spin_for(0.3)
        assert h.received["detections"] == [], "answered before its hand-over target came"
        box0 = true_box(*target_position(0))
        h.publish("handover_target", target_msg(0, box0))
        h.spin_until(lambda: len(h.received["detections"]) == 1)
        [blob] = h.received["detections"][0].blobs  # tracked in the image it was handed over in
        assert msg_to_rect(blob.bbox).iou(box0) >= 0.5
        image = array_to_image(scene_with_target(1), "bgr8", ns_to_stamp(NS), "camera")
        h.publish("camera/image_raw", image)
        h.publish("handover_target", target_msg(1, true_box(*target_position(1))))
        h.spin_for(0.3)
        assert len(h.received["detections"]) == 1, "answered before its tracker's last target"
        h.publish("target", target_msg(0, box0))
        h.spin_until(lambda: len(h.received["detections"]) == 2)
        [blob] = h.received["detections"][1].blobs
        assert msg_to_rect(blob.bbox).iou(true_box(*target_position(1))) >= 0.5
    finally:
        h.close()


def test_lockstep_targets_wait_at_most_the_timeout_when_no_tracker_answers():
    h = harness(lockstep_targets=True, target_timeout=0.3)
    try:
        for k in range(3):
            send(h, k)  # answered after the timeout, each
        assert h.node.problems.counts.get("targets late", 0) >= 3
    finally:
        h.close()
