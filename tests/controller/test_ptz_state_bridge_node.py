"""The ptz_state_bridge node: JointState + CameraInfo in, one PtzState per image out, stamped like
the image; bad input is reported and changes nothing."""

from __future__ import annotations

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from hostile_messages import (  # noqa: E402
    Field,
    HostileSource,
    all_finite,
    assert_unchanged_by_hostile_messages,
    feed_hostile,
    record_publishes,
)
from node_harness import NodeHarness  # noqa: E402
from ptz_messages import state_values  # noqa: E402
from sensor_msgs.msg import CameraInfo, JointState  # noqa: E402

from tracker_msgs.msg import PtzState  # noqa: E402
from tracker_msgs_py.codec import camera_info, ns_to_stamp, result_qos, stamp_to_ns  # noqa: E402
from tracker_ptz_sim.control.ptz_state_bridge_node import PtzStateBridgeNode  # noqa: E402

pytestmark = pytest.mark.ros
MS = 1_000_000


def joints(stamp_ns: int, pan: float, names=("pan_joint", "tilt_joint")) -> JointState:
    msg = JointState(name=list(names), position=[pan, 0.0][: len(names)])
    msg.header.stamp = ns_to_stamp(stamp_ns)
    return msg


def info(stamp_ns: int, fx: float = 500.0) -> CameraInfo:
    return camera_info(640, 480, fx, fx, 320.0, 240.0, ns_to_stamp(stamp_ns), "camera")


def bridge_harness() -> NodeHarness:
    """The bridge over a 2000 x 1000 px scene, fed joint states and camera infos."""
    return NodeHarness(
        PtzStateBridgeNode,
        inputs={"ptz/joint_states": (JointState, 10), "camera/camera_info": (CameraInfo, 10)},
        outputs={"ptz/state": (PtzState, result_qos())},
        scene_width=2000,
        scene_height=1000,
    )


@pytest.fixture
def harness():
    h = bridge_harness()
    yield h
    h.close()


def states(h):
    return h.received["ptz/state"]


def test_each_image_gets_the_pose_at_its_stamp(harness):
    harness.publish("ptz/joint_states", joints(0, 0.0))
    harness.publish("camera/camera_info", info(50 * MS))
    harness.spin_for(0.05)
    harness.publish("ptz/joint_states", joints(100 * MS, 0.2))
    harness.spin_until(lambda: len(states(harness)) == 1)
    (state,) = states(harness)
    assert stamp_to_ns(state.header.stamp) == 50 * MS and state.header.frame_id == "scene"
    assert state.pan == pytest.approx(0.1) and state.focal_length == 500.0
    assert state.window.x + state.window.width / 2 == pytest.approx(1000 - 50.0, abs=0.5)
    assert state.moving


def test_bad_joint_states_and_camera_infos_are_reported_once_and_change_nothing(harness, capfd):
    for _ in range(3):
        harness.publish("ptz/joint_states", joints(0, 0.3, names=("other_joint",)))
        harness.publish("camera/camera_info", info(0, fx=0.0))
    harness.spin_for(0.3)
    assert states(harness) == []
    log = capfd.readouterr().err
    assert log.count("ignored a JointState without positions for") == 1
    assert log.count("ignored a CameraInfo") == 1
    harness.publish("ptz/joint_states", joints(0, 0.3))
    harness.publish("camera/camera_info", info(0))
    harness.spin_until(lambda: len(states(harness)) == 1)
    assert states(harness)[0].pan == 0.3


def test_an_image_without_a_newer_joint_state_gets_the_latest_one_after_pose_wait(harness):
    harness.publish("ptz/joint_states", joints(0, -0.1))
    harness.spin_for(0.05)
    harness.publish("camera/camera_info", info(100 * MS))  # the unit publishes nothing newer
    harness.spin_until(lambda: len(states(harness)) == 1, timeout=2.0)
    assert states(harness)[0].pan == -0.1


def test_an_axis_like_unit_its_signs_and_its_commanded_motion():
    """Joints that count pan clockwise and tilt up (joint_signs -1), reported once a second with
    zero velocities (pose_wait 0): images between joint states get the latest one carried forward
    by the commanded rate, in REP-103 angles."""
    from tracker_msgs.msg import PtzCommand
    from tracker_msgs_py.codec import command_qos

    h = NodeHarness(
        PtzStateBridgeNode,
        inputs={
            "ptz/joint_states": (JointState, 10),
            "camera/camera_info": (CameraInfo, 10),
            "ptz/command": (PtzCommand, command_qos()),
        },
        outputs={"ptz/state": (PtzState, result_qos())},
        scene_width=2000,
        scene_height=1000,
        joint_signs=[-1.0, -1.0],
        joint_offsets=[0.1, 0.0],
        pose_wait=0.0,
        max_pose_age=1.5,
    )
    try:
        axis_state = joints(0, 0.0)
        axis_state.position = [0.1 - 0.2, -0.05]  # REP-103 pan 0.2, tilt 0.05 (down)
        axis_state.velocity = [0.0, 0.0]
        h.publish("ptz/joint_states", axis_state)
        h.spin_for(0.05)
        command = PtzCommand(mode=PtzCommand.MODE_VELOCITY, pan_rate=0.5, tilt_rate=0.0)
        command.header.stamp = ns_to_stamp(0)
        h.publish("ptz/command", command)
        h.spin_for(0.05)
        h.publish("camera/camera_info", info(400 * MS))
        h.spin_until(lambda: len(states(h)) == 1, timeout=2.0)
        (state,) = states(h)
        assert state.pan == pytest.approx(0.2 + 0.5 * 0.4)  # carried 0.4 s at 0.5 rad/s
        assert state.tilt == pytest.approx(0.05)
        assert state.pan_rate == pytest.approx(0.5) and state.moving
    finally:
        h.close()


JOINT_FIELDS = [
    Field("position[0]"),
    Field("position[1]"),
    Field("velocity[0]", nan_means_unset=True),
    Field("velocity[1]", nan_means_unset=True),
]
INFO_FIELDS = [
    Field("k[0]", positive=True),
    Field("k[4]", positive=True),
    Field("k[2]"),
    Field("k[5]"),
]


def moving_joints(stamp_ns: int, k: int = 0) -> JointState:
    msg = joints(stamp_ns, 0.02 * k)
    msg.velocity = [0.2, 0.0]
    return msg


def test_hundreds_of_hostile_messages_change_no_good_answer_and_nothing_non_finite_leaves(capfd):
    """Seeded: 20 images (a CameraInfo half a frame after a joint state, released by the next),
    and after each 15 hostile joint states (a position or velocity non-finite or huge) or
    CameraInfos (fx, fy, cx or cy non-finite, huge or negative), stamped between frames, far
    ahead, back in time, on the last frame, the next frame's or before zero. The poses of the
    good images are the clean run's, every PtzState published is finite, and each cause is
    logged once."""
    rng = np.random.default_rng(67)
    frame = 100 * MS
    sources = [
        HostileSource("ptz/joint_states", moving_joints, JOINT_FIELDS),
        HostileSource("camera/camera_info", info, INFO_FIELDS),
    ]

    def run(hostile: bool):
        h = bridge_harness()
        published = record_publishes(h.node.state_pub)
        try:
            answers = []
            h.feed("ptz/joint_states", moving_joints(0))
            for k in range(1, 21):
                image_ns = k * frame - frame // 2
                h.feed("camera/camera_info", info(image_ns))
                h.feed("ptz/joint_states", moving_joints(k * frame, k))
                good = [s for s in published if stamp_to_ns(s.header.stamp) == image_ns]
                assert good, f"image {k} not answered"
                answers.append(state_values(good[-1]))
                if hostile:
                    feed_hostile(h, rng, sources, k * frame, frame)
            assert all(all_finite(state_values(s)) for s in published)
            return answers, dict(h.node.problems.counts)
        finally:
            h.close()

    assert_unchanged_by_hostile_messages(run, capfd, counted_at_least=250)
