"""ptz_controller's commands as sensor_msgs/JointState, what a real unit's driver takes: positions or
velocities, the zoom joint when the zoom changes, and a stop when the controller shuts down."""

from __future__ import annotations

import math

import pytest

rclpy = pytest.importorskip("rclpy")

from node_harness import NodeHarness  # noqa: E402
from ptz_messages import state_msg, target_msg  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402

from tracker_msgs.msg import PtzState, Target  # noqa: E402
from tracker_msgs_py.codec import command_qos  # noqa: E402
from tracker_ptz_sim.control.controller import Command, CommandMode  # noqa: E402
from tracker_ptz_sim.control.ptz_controller_node import (  # noqa: E402
    PtzControllerNode,
    joint_command,
)

pytestmark = pytest.mark.ros
NAMES = ["pan_joint", "tilt_joint"]


def test_a_position_command_with_a_zoom_change_names_the_zoom_joint():
    command = Command(CommandMode.POSITION, pan=0.1, tilt=-0.2, zoom=1.5)
    joints = joint_command(command, None, NAMES, "zoom")
    assert list(joints.name) == NAMES + ["zoom"]
    assert list(joints.position) == [0.1, -0.2, 1.5] and list(joints.velocity) == []


def test_a_velocity_command_with_a_zoom_change_marks_what_is_not_commanded_with_nan():
    command = Command(CommandMode.VELOCITY, pan_rate=0.3, tilt_rate=0.0, zoom=0.8)
    joints = joint_command(command, None, NAMES, "zoom")
    assert list(joints.velocity[:2]) == [0.3, 0.0] and math.isnan(joints.velocity[2])
    assert all(math.isnan(v) for v in joints.position[:2]) and joints.position[2] == 0.8


def test_without_a_zoom_change_only_pan_and_tilt_are_commanded():
    joints = joint_command(Command(CommandMode.HOLD), None, NAMES, "zoom")
    assert list(joints.name) == NAMES and list(joints.velocity) == [0.0, 0.0]


def test_the_controller_stops_the_unit_when_it_shuts_down():
    h = NodeHarness(
        PtzControllerNode,
        inputs={"ptz/state": (PtzState, 50), "target": (Target, 50)},
        outputs={"ptz/joint_command": (JointState, command_qos())},
        joint_command_topic="ptz/joint_command",
    )
    try:
        h.publish("ptz/state", state_msg(100_000_000))
        h.publish("target", target_msg(100_000_000, x=480.0))
        h.spin_until(lambda: len(h.received["ptz/joint_command"]) == 1)
        turning = h.received["ptz/joint_command"][0]
        assert turning.velocity[0] != 0.0
        h.executor.remove_node(h.node)
        h.node.destroy_node()
        h.spin_until(lambda: len(h.received["ptz/joint_command"]) == 2)
        stop = h.received["ptz/joint_command"][1]
        assert list(stop.velocity) == [0.0, 0.0]
        assert stop.header.stamp == turning.header.stamp  # the last image answered
    finally:
        h.close()
