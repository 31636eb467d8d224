"""A node whose peer's QoS cannot match says so, once, naming the cause and the fix (rclpy's own
sign is an rcl warning that names neither), and counts it on /diagnostics."""

from __future__ import annotations

import time

import pytest

rclpy = pytest.importorskip("rclpy")
pytestmark = pytest.mark.ros

from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from sensor_msgs.msg import Image  # noqa: E402

from tracker_msgs_py.codec import image_qos  # noqa: E402
from tracker_msgs_py.node_main import SuiteNode  # noqa: E402


class ReliableImages(SuiteNode):
    def __init__(self, **options) -> None:
        super().__init__("reliable_images_node", **options)
        self.create_subscription(Image, "camera/image_raw", lambda _: None, image_qos(True))
        self.create_publisher(Image, "camera/view", image_qos(False))


def spin_until(executor, condition, timeout=10.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        executor.spin_once(timeout_sec=0.05)


def test_a_best_effort_camera_and_a_reliable_subscription_are_reported_with_the_fix(capfd):
    context = rclpy.Context()
    rclpy.init(context=context)
    node = ReliableImages(context=context)
    peer = rclpy.create_node("camera_driver", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    executor.add_node(peer)
    try:
        peer.create_publisher(Image, "camera/image_raw", image_qos(False))  # a driver's QoS
        peer.create_subscription(Image, "camera/view", lambda _: None, image_qos(True))
        causes = ("incompatible QoS on camera/image_raw", "incompatible QoS on camera/view")
        spin_until(executor, lambda: all(node.problems.counts.get(c) for c in causes))
        log = capfd.readouterr().err
        assert "/camera/image_raw: a peer's QoS cannot match this node's (reliability)" in log
        assert "set reliable_images:=false" in log
        assert "A best-effort publisher here cannot serve a reliable subscriber" in log
    finally:
        executor.shutdown()
        node.destroy_node()
        peer.destroy_node()
        rclpy.shutdown(context=context)


def test_an_image_streams_qos_is_overridable_by_parameter():
    """`qos_overrides./camera/image_raw.subscription.reliability:=reliable` (and depth) on a
    detector with best-effort images, as QoSOverridingOptions reads them; results keep theirs."""
    rclpy = pytest.importorskip("rclpy")
    from rclpy.parameter import Parameter
    from rclpy.qos import ReliabilityPolicy

    from tracker_detect.detector_node import DetectorNode

    context = rclpy.Context()
    rclpy.init(context=context)
    prefix = "qos_overrides./camera/image_raw.subscription"
    node = DetectorNode(
        context=context,
        parameter_overrides=[
            Parameter("reliable_images", value=False),
            Parameter("method", value="ssim_background"),
            Parameter(f"{prefix}.reliability", value="reliable"),
            Parameter(f"{prefix}.depth", value=3),
        ],
    )
    try:
        (images,) = [s for s in node.subscriptions if s.topic_name == "/camera/image_raw"]
        assert images.qos_profile.reliability == ReliabilityPolicy.RELIABLE
        assert images.qos_profile.depth == 3
        assert node.get_parameter(f"{prefix}.reliability").value == "reliable"
        assert not node.has_parameter("qos_overrides./detections.publisher.reliability")
    finally:
        node.destroy_node()
        rclpy.shutdown(context=context)
