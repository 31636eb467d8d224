"""Every small per-frame result the demo records is published with a deep reliable history,
kept for late joiners: the recorder gets results published before it was discovered.

A keep-last writer retransmits a lost sample only while it is still in its history; with the
ROS default depth of 10 a recorder that stalled for a moment under load lost a few frames'
detections, tracks and pan-tilt states from its bag (the replay had moved on by more than 10
frames before the retransmission was asked for). This checks the history of each node's
publisher of every non-image topic of both graphs (discovery does not carry the depth, so the
publishers are read from the nodes themselves)."""

from __future__ import annotations

import pytest

rclpy = pytest.importorskip("rclpy")

from rclpy.parameter import Parameter  # noqa: E402
from rclpy.qos import DurabilityPolicy, ReliabilityPolicy  # noqa: E402

from tracker_detect.detector_node import DetectorNode  # noqa: E402
from tracker_filter.tracker_node import TrackerNode  # noqa: E402
from tracker_msgs_py.codec import (  # noqa: E402
    COMMAND_DEPTH,
    RESULT_DEPTH,
    is_command_topic,
    result_qos,
)
from tracker_ptz_sim.bringup.graph import GRAPHS, load_graph  # noqa: E402
from tracker_ptz_sim.control.ptz_controller_node import PtzControllerNode  # noqa: E402
from tracker_ptz_sim.control.ptz_state_bridge_node import PtzStateBridgeNode  # noqa: E402
from tracker_ptz_sim.simulation.ptz_camera_node import PtzCameraNode  # noqa: E402

pytestmark = pytest.mark.ros
# Published by the video source (images, camera info, clock, status) or not per-frame results.
NOT_RESULTS = {"/clock", "/replay/status", "/scene/image_raw", "/scene/camera_info"}
# The controller as the standard graph runs it: also JointState commands for a real unit's driver.
NODES = [
    (PtzCameraNode, {}),
    (DetectorNode, {}),
    (TrackerNode, {}),
    (PtzControllerNode, {"joint_command_topic": "ptz/joint_command"}),
    (PtzStateBridgeNode, {}),
]


@pytest.fixture
def running_nodes():
    context = rclpy.Context()
    rclpy.init(context=context)
    nodes = [
        make(
            context=context, parameter_overrides=[Parameter(k, value=v) for k, v in params.items()]
        )
        for make, params in NODES
    ]
    yield nodes
    for node in nodes:
        node.destroy_node()
    rclpy.shutdown(context=context)


def result_topics() -> set[str]:
    topics = {t.name for graph in GRAPHS for t in load_graph(graph).topics}
    images = {t for t in topics if t.endswith(("image_raw", "camera_info"))}
    return topics - NOT_RESULTS - images


def test_every_recorded_result_is_published_reliably_with_a_deep_history(running_nodes):
    # One node of each kind in its default namespace: the colour graph's /motion/* copies are
    # the same executables remapped, so the unprefixed topic stands for both.
    offered = {
        publisher.topic_name: publisher.qos_profile
        for node in running_nodes
        for publisher in node.publishers
    }
    topics = {t.removeprefix("/motion") for t in result_topics() if not is_command_topic(t)}
    assert topics <= offered.keys(), f"no node publishes {topics - offered.keys()}"
    shallow = {
        topic: (offered[topic].reliability.name, offered[topic].depth)
        for topic in topics
        if offered[topic].reliability != ReliabilityPolicy.RELIABLE
        or offered[topic].depth < RESULT_DEPTH
        or offered[topic].durability != DurabilityPolicy.TRANSIENT_LOCAL
    }
    assert not shallow, f"published with a shallow, best-effort or volatile history: {shallow}"


def test_commands_are_volatile_with_a_small_history(running_nodes):
    offered = {
        publisher.topic_name: publisher.qos_profile
        for node in running_nodes
        for publisher in node.publishers
    }
    commands = {t for t in result_topics() if is_command_topic(t)}
    assert commands == {"/ptz/command", "/ptz/joint_command"}
    for topic in commands:
        qos = offered[topic]
        assert qos.durability == DurabilityPolicy.VOLATILE, topic
        assert qos.reliability == ReliabilityPolicy.RELIABLE and qos.depth == COMMAND_DEPTH, topic


def test_a_command_subscriber_created_after_100_commands_receives_none_of_them():
    """A late driver (or a relay asking for transient local) must not act on old commands: a
    transient-local reader does not match at all, a volatile one gets only what comes after it."""
    from node_harness import NodeHarness
    from ptz_messages import state_msg, target_msg

    from tracker_msgs.msg import PtzCommand, PtzState, Target

    h = NodeHarness(
        PtzControllerNode,
        inputs={"ptz/state": (PtzState, 50), "target": (Target, 50)},
        outputs={},
        mode="servo",
    )
    try:
        for k in range(100):
            h.feed("ptz/state", state_msg(k * 100_000_000))
            h.feed("target", target_msg(k * 100_000_000))
        late, volatile = [], []
        h.peer.create_subscription(PtzCommand, "ptz/command", late.append, result_qos())
        h.peer.create_subscription(PtzCommand, "ptz/command", volatile.append, 10)
        h.spin_until(lambda: h.node.command_pub.get_subscription_count() == 1)
        h.spin_for(0.5)
        assert late == [] and volatile == []
        h.feed("ptz/state", state_msg(100 * 100_000_000))
        h.feed("target", target_msg(100 * 100_000_000))
        h.spin_until(lambda: len(volatile) == 1)
        assert late == [] and volatile[0].header.stamp.sec == 10
    finally:
        h.close()


class _Bag:
    def __init__(self) -> None:
        self.written: dict[str, int] = {}

    def write(self, topic: str, _stamp_ns: int, _data: bytes) -> None:
        self.written[topic] = self.written.get(topic, 0) + 1


def test_the_recorder_gets_results_published_before_it_was_discovered():
    """What lost frame 1's tracks and command from a CI bag: the writer had not yet learnt of the
    recorder when it published. Here the recorder does not even exist yet."""
    import time

    from rclpy.executors import SingleThreadedExecutor

    from tracker_msgs.msg import Target
    from tracker_ptz_sim.bringup.demo import Recorder

    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        early = rclpy.create_node("early_publisher", context=context)
        publisher = early.create_publisher(Target, "target", result_qos())
        for _ in range(3):
            publisher.publish(Target())
        bag = _Bag()
        recorder = Recorder(load_graph(), bag, context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(recorder)
        deadline = time.monotonic() + 10.0
        while bag.written.get("/target", 0) < 3 and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
        recorder.close()
        assert bag.written.get("/target") == 3
        recorder.destroy_node()
        early.destroy_node()
    finally:
        rclpy.shutdown(context=context)
