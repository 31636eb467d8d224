"""The onvif_ptz node driving the tests' ONVIF camera: rates as ContinuousMove, holds as Stop,
direct moves as AbsoluteMove, the pose published as joint states, the return preset after a
target is lost, a stop at shutdown, one clear line for a camera it cannot use."""

from __future__ import annotations

import dataclasses
import time

import pytest

rclpy = pytest.importorskip("rclpy")
pytest.importorskip("onvif")

from node_harness import NodeHarness  # noqa: E402
from onvif_camera import OnvifCamera  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from tracker_msgs.msg import PtzCommand, Target  # noqa: E402
from tracker_msgs_py.codec import command_qos, result_qos  # noqa: E402
from tracker_msgs_py.node_main import StartupError  # noqa: E402
from tracker_ptz_sim.control.onvif_ptz_node import OnvifPtzNode  # noqa: E402

pytestmark = pytest.mark.ros
PAN_RANGE = [1.0, -1.0]  # rad at x = -1, +1: generic 0.5 is 0.5 rad to the right


def node_for(camera, extra_outputs=None, **params):
    defaults = {
        "host": "127.0.0.1",
        "port": camera.port,
        "pan_range": PAN_RANGE,
        "tilt_range": [1.0, -1.0],
        "top_rates": [0.5, 0.5],  # the camera's top speed: 0.5 generic units/s = 0.5 rad/s here
        "status_rate": 20.0,
    }
    return NodeHarness(
        OnvifPtzNode,
        inputs={"ptz/command": (PtzCommand, command_qos()), "target": (Target, 10)},
        outputs={"ptz/joint_states": (JointState, result_qos()), **(extra_outputs or {})},
        **{**defaults, **params},
    )


def velocity(pan_rate=0.0, tilt_rate=0.0):
    return PtzCommand(mode=PtzCommand.MODE_VELOCITY, pan_rate=pan_rate, tilt_rate=tilt_rate)


def test_rates_holds_and_direct_moves_reach_the_camera_and_its_pose_comes_back():
    with OnvifCamera(user="admin", password="secret") as camera:
        h = node_for(camera, user="admin", password="secret")
        try:
            h.publish("ptz/command", velocity(pan_rate=-0.25))  # to the right at half speed
            h.spin_until(lambda: camera.calls("ContinuousMove"), timeout=5.0)
            (move,) = camera.calls("ContinuousMove")
            assert move["Velocity"].PanTilt.x == pytest.approx(0.5)
            h.spin_for(0.5)
            h.publish("ptz/command", PtzCommand(mode=PtzCommand.MODE_HOLD))
            h.spin_until(lambda: camera.calls("Stop"), timeout=5.0)
            x, _ = camera.pose()
            assert 0.1 < x < 0.2  # 0.25 units/s for about half a second
            h.received["ptz/joint_states"].clear()
            h.spin_until(lambda: len(h.received["ptz/joint_states"]) >= 3, timeout=5.0)
            state = h.received["ptz/joint_states"][-1]
            assert list(state.name) == ["pan_joint", "tilt_joint"]
            assert state.position[0] == pytest.approx(-x, abs=1e-6)  # REP-103: right is -
            stamp = state.header.stamp.sec + state.header.stamp.nanosec * 1e-9
            assert abs(stamp - time.time()) < 0.5  # stamped when the camera was asked
            direct = PtzCommand(mode=PtzCommand.MODE_POSITION, pan=0.3, tilt=-0.2)
            h.publish("ptz/command", direct)
            h.spin_until(lambda: camera.calls("AbsoluteMove"), timeout=5.0)
            goal = camera.calls("AbsoluteMove")[0]["Position"].PanTilt
            assert (goal.x, goal.y) == pytest.approx((-0.3, 0.2))
            for _ in range(5):  # a repeated command is not sent again
                h.publish("ptz/command", direct)
            h.spin_for(0.3)
            assert len(camera.calls("AbsoluteMove")) == 1
            h.publish("ptz/command", velocity(tilt_rate=0.1))
            h.spin_until(lambda: len(camera.calls("ContinuousMove")) == 2, timeout=5.0)
            stops = len(camera.calls("Stop"))
            h.executor.remove_node(h.node)
            h.node.destroy_node()
            assert len(camera.calls("Stop")) == stops + 1  # stopped at shutdown
        finally:
            h.close()


def test_after_return_after_without_a_target_the_camera_waits_at_its_preset():
    with OnvifCamera(presets={"home": (0.0, 0.0), "gate": (0.4, 0.0)}) as camera:
        h = node_for(camera, return_preset="gate", return_after=0.5)
        try:
            h.spin_until(lambda: camera.calls("GotoPreset"), timeout=5.0)
            assert camera.calls("GotoPreset")[0]["PresetToken"] == "gate"
            h.publish("ptz/command", velocity(pan_rate=0.2))  # the search: not obeyed
            h.spin_for(0.3)
            assert camera.calls("ContinuousMove") == []
            h.publish("target", Target(locked=True))
            h.spin_for(0.1)
            h.publish("ptz/command", velocity(pan_rate=0.2))
            h.spin_until(lambda: camera.calls("ContinuousMove"), timeout=5.0)
        finally:
            h.close()


def test_a_camera_that_never_reports_idle_is_judged_still_by_its_position():
    with OnvifCamera(never_idle=True) as camera:
        h = node_for(camera)
        try:
            h.spin_until(lambda: len(h.received["ptz/joint_states"]) >= 5, timeout=5.0)
            assert not h.node.moving
            h.publish("ptz/command", velocity(pan_rate=0.4))
            h.spin_until(lambda: h.node.moving, timeout=5.0)
        finally:
            h.close()


def test_a_camera_without_position_moves_gets_rates_toward_the_goal():
    with OnvifCamera(fov_moves=False) as camera:
        h = node_for(camera)
        try:
            # as a camera with continuous moves alone reports itself
            h.node.support = dataclasses.replace(h.node.support, absolute=False, relative=False)
            h.spin_until(lambda: h.node.pose is not None, timeout=5.0)
            h.publish("ptz/command", PtzCommand(mode=PtzCommand.MODE_POSITION, pan=-0.5))
            h.spin_until(lambda: camera.calls("ContinuousMove"), timeout=5.0)
            x_velocity = camera.calls("ContinuousMove")[0]["Velocity"].PanTilt.x
            assert x_velocity == pytest.approx(1.0)  # gain 2 x 0.5 rad = 1 rad/s: top speed
        finally:
            h.close()


@pytest.mark.parametrize(
    ("camera_options", "params", "cause"),
    [
        ({"user": "admin", "password": "secret"}, {"password": "wrong"}, "user name or password"),
        ({"status_position": False}, {}, "reports no position"),
        ({}, {"profile": "other"}, "no profile 'other'"),
    ],
)
def test_a_camera_it_cannot_use_is_one_clear_start_up_error(camera_options, params, cause):
    with OnvifCamera(**camera_options) as camera, pytest.raises(StartupError, match=cause):
        node_for(camera, user="admin", **params)


def test_calibration_measures_the_pan_rate_and_brings_the_head_back():
    with OnvifCamera(top_speed=(0.5, 0.5)) as camera:
        latency = {"ptz/unit_latency": (Float64, result_qos())}
        h = node_for(camera, latency, calibrate=True, top_rates=[2.0, 0.5])  # a wrong pan rate
        try:
            # 0.5 generic units/s at velocity 1 over a range of 1 rad per unit: 0.5 rad/s
            assert h.node.range.top_rates[0] == pytest.approx(0.5, rel=0.15)
            assert h.node.calibration.latency < 0.3
            h.spin_until(lambda: abs(camera.pose()[0]) < 1e-3, timeout=5.0)  # back at the start
            # the latency for the controller, on a topic a later subscriber still gets
            h.spin_until(lambda: h.received["ptz/unit_latency"])
            sent = h.received["ptz/unit_latency"]
            assert [m.data for m in sent] == [pytest.approx(h.node.calibration.latency)]
        finally:
            h.close()
