"""ptz_controller publishing JointState commands: the FLIR PTU driver's form through a whole run
(servo moves, holds, the search), and a stop when the controller shuts down."""

from __future__ import annotations

import pytest

rclpy = pytest.importorskip("rclpy")

from node_harness import NodeHarness  # noqa: E402
from ptz_messages import state_msg, target_msg  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from unit_contracts import flir_ptu_contract_problem  # noqa: E402

from tracker_msgs.msg import PtzState, Target  # noqa: E402
from tracker_msgs_py.codec import command_qos  # noqa: E402
from tracker_ptz_sim.control.ptz_controller_node import PtzControllerNode  # noqa: E402
from tracker_ptz_sim.control.unit_joints import JointCommand  # noqa: E402

pytestmark = pytest.mark.ros
NS = 100_000_000


def controller(**params):
    return NodeHarness(
        PtzControllerNode,
        inputs={"ptz/state": (PtzState, 50), "target": (Target, 50)},
        outputs={"ptz/joint_command": (JointState, command_qos())},
        joint_command_topic="ptz/joint_command",
        **params,
    )


def test_the_controller_stops_the_unit_when_it_shuts_down():
    h = controller()
    try:
        h.publish("ptz/state", state_msg(NS))
        h.publish("target", target_msg(NS, x=480.0))
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


def test_a_run_in_the_flir_style_sends_only_what_the_flir_ptu_driver_accepts():
    """Following a target, losing it (holds, then the search's direct moves to presets) and the
    stop at shutdown: every JointState has two positions and two speeds within the unit's range."""
    h = controller(
        joint_command_style="positions_with_speeds",
        joint_names=["ptu_pan", "ptu_tilt"],
        joint_speed_limits=[0.0087, 0.87],
        pan_limits=[-2.7, 2.7],
        tilt_limits=[-0.8, 0.5],
        search="presets",
        lost_scan_time=0.0,
        presets=[0.5, 0.1, -0.5, 0.1],
    )
    try:
        frames = 40
        for k in range(1, frames + 1):
            h.publish("ptz/state", state_msg(k * NS, pan=0.01 * k))
            h.publish("target", target_msg(k * NS, x=480.0, locked=k <= 15))
            h.spin_until(lambda k=k: len(h.received["ptz/joint_command"]) == k)
        h.executor.remove_node(h.node)
        h.node.destroy_node()
        h.spin_until(lambda: len(h.received["ptz/joint_command"]) == frames + 1)
        unit = h.node.unit
        speeds = []
        for msg in h.received["ptz/joint_command"]:
            joints = JointCommand(list(msg.name), list(msg.position), list(msg.velocity))
            assert flir_ptu_contract_problem(joints, unit) is None, msg
            speeds.append(tuple(joints.velocities))
        assert speeds[0][0] > 0.0087  # following: the pan speed is the servo's rate
        assert (0.87, 0.87) in speeds  # the search's direct move to a preset goes at top speed
    finally:
        h.close()


def test_the_axis_adapter_sends_rates_in_the_cameras_joints_and_a_stop_at_shutdown():
    from ptz_action_server_msgs.msg import Ptz

    from tracker_msgs.msg import PtzCommand
    from tracker_ptz_sim.control.axis_ptz_adapter_node import AxisPtzAdapterNode

    h = NodeHarness(
        AxisPtzAdapterNode,
        inputs={"ptz/command": (PtzCommand, command_qos()), "ptz/state": (PtzState, 10)},
        outputs={"cmd/velocity": (Ptz, command_qos())},
        joint_signs=[-1.0, -1.0],
    )
    try:
        h.publish("ptz/state", state_msg(NS, pan=0.1))
        h.spin_for(0.05)
        sent = h.received["cmd/velocity"]
        commands = [
            PtzCommand(mode=PtzCommand.MODE_VELOCITY, pan_rate=0.25, tilt_rate=-0.125),
            PtzCommand(mode=PtzCommand.MODE_POSITION, pan=0.35, tilt=0.0),
            PtzCommand(mode=PtzCommand.MODE_VELOCITY, pan_rate=float("nan")),
            PtzCommand(mode=PtzCommand.MODE_HOLD),
        ]
        for k, command in enumerate(commands, start=1):
            h.publish("ptz/command", command)
            h.spin_until(lambda k=k: len(sent) == k)
        rates = [(m.pan, m.tilt, m.zoom) for m in sent]
        assert rates[0] == pytest.approx((-0.25, 0.125, 0.0))  # clockwise pan, tilt + = up
        assert rates[1] == pytest.approx((-0.5, 0.0, 0.0))  # 2/s x 0.25 rad to go
        assert rates[2] == (0.0, 0.0, 0.0) and rates[3] == (0.0, 0.0, 0.0)  # NaN: a stop
        sent.clear()
        h.publish("ptz/command", commands[0])
        h.spin_until(lambda: len(sent) == 1)
        h.executor.remove_node(h.node)
        h.node.destroy_node()
        h.spin_until(lambda: len(sent) == 2)
        assert (sent[1].pan, sent[1].tilt) == (0.0, 0.0)
    finally:
        h.close()
