"""The ptz_state_bridge node: JointState + CameraInfo in, one PtzState per image out, stamped like
the image; bad input is reported and changes nothing."""

from __future__ import annotations

import pytest

rclpy = pytest.importorskip("rclpy")

from node_harness import NodeHarness  # noqa: E402
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


@pytest.fixture
def harness():
    h = NodeHarness(
        PtzStateBridgeNode,
        inputs={"ptz/joint_states": (JointState, 10), "camera/camera_info": (CameraInfo, 10)},
        outputs={"ptz/state": (PtzState, result_qos())},
        scene_width=2000,
        scene_height=1000,
    )
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
