"""ptz_controller's commands as sensor_msgs/JointState, in the form a real unit's driver takes:
velocities or positions (the zoom joint when the zoom changes), the FLIR PTU driver's positions
with speeds (checked against that driver's message contract), the unit's joint signs and offsets,
and a stop when the controller shuts down."""

from __future__ import annotations

import math

import numpy as np
import pytest
from unit_contracts import flir_ptu_contract_problem

from tracker_ptz_sim.control.controller import CameraPose, Command, CommandMode
from tracker_ptz_sim.control.unit_joints import (
    CommandedMotion,
    CommandStyle,
    JointMapping,
    UnitSettings,
    unit_command,
)

NAMES = ("pan_joint", "tilt_joint")
VELOCITY = UnitSettings(NAMES, zoom_joint="zoom")
FLIR_SPEEDS = (0.0087, 0.87)  # rad/s: a D46's base and top speed, as its driver logs them
FLIR = UnitSettings(
    ("ptu_pan", "ptu_tilt"),
    CommandStyle.POSITIONS_WITH_SPEEDS,
    speed_limits=FLIR_SPEEDS,
    pan_limits=(-2.7, 2.7),
    tilt_limits=(-0.8, 0.5),
)
POSE = CameraPose(pan=0.2, tilt=-0.1, center_x=400.0, center_y=300.0, focal_length=440.0)


def test_a_position_command_with_a_zoom_change_names_the_zoom_joint():
    command = Command(CommandMode.POSITION, pan=0.1, tilt=-0.2, zoom=1.5)
    joints = unit_command(command, None, VELOCITY)
    assert joints.names == [*NAMES, "zoom"]
    assert joints.positions == [0.1, -0.2, 1.5] and joints.velocities == []


def test_a_velocity_command_with_a_zoom_change_marks_what_is_not_commanded_with_nan():
    command = Command(CommandMode.VELOCITY, pan_rate=0.3, tilt_rate=0.0, zoom=0.8)
    joints = unit_command(command, None, VELOCITY)
    assert joints.velocities[:2] == [0.3, 0.0] and math.isnan(joints.velocities[2])
    assert all(math.isnan(v) for v in joints.positions[:2]) and joints.positions[2] == 0.8


def test_without_a_zoom_change_only_pan_and_tilt_are_commanded():
    joints = unit_command(Command(CommandMode.HOLD), None, VELOCITY)
    assert joints.names == list(NAMES) and joints.velocities == [0.0, 0.0]


def test_every_command_of_every_mode_meets_the_flir_ptu_drivers_contract():
    rng = np.random.default_rng(7)
    for _ in range(2000):
        mode = CommandMode(rng.choice([m.value for m in CommandMode]))
        pan, tilt = rng.uniform(-4.0, 4.0, 2)  # direct moves beyond the range are kept within it
        rates = rng.uniform(-3.0, 3.0, 2) * rng.choice([0.0, 0.001, 1.0])
        command = Command(mode, pan, tilt, *rates)
        pose = CameraPose(*rng.uniform(-0.5, 0.5, 2), 400.0, 300.0, 440.0)
        joints = unit_command(command, pose, FLIR)
        assert flir_ptu_contract_problem(joints, FLIR) is None, (command, joints)
        assert joints.names == ["ptu_pan", "ptu_tilt"]


def test_a_flir_rate_is_a_goal_ahead_of_the_images_pose_at_that_speed():
    joints = unit_command(Command(CommandMode.VELOCITY, pan_rate=-0.4, tilt_rate=0.1), POSE, FLIR)
    assert joints.positions == pytest.approx([0.2 - 0.4 * FLIR.lead, -0.1 + 0.1 * FLIR.lead])
    assert joints.velocities == pytest.approx([0.4, 0.1])
    hold = unit_command(Command(CommandMode.HOLD), POSE, FLIR)
    assert hold.positions == pytest.approx([0.2, -0.1])  # stay where the image was taken
    assert hold.velocities == pytest.approx([FLIR_SPEEDS[0]] * 2)
    direct = unit_command(Command(CommandMode.POSITION, pan=1.0, tilt=0.3), POSE, FLIR)
    assert direct.positions == pytest.approx([1.0, 0.3])
    assert direct.velocities == pytest.approx([FLIR_SPEEDS[1]] * 2)  # a direct move goes fast


def test_a_flir_rate_without_the_images_pose_is_not_sent():
    joints = unit_command(Command(CommandMode.VELOCITY, pan_rate=0.4), None, FLIR)
    assert joints.positions == [] and joints.velocities == []


def test_the_flir_style_refuses_a_zoom_joint():
    with pytest.raises(ValueError, match="exactly two positions"):
        UnitSettings(style=CommandStyle.POSITIONS_WITH_SPEEDS, zoom_joint="zoom")


def test_joint_signs_and_offsets_map_both_ways():
    axis = JointMapping(signs=(-1.0, -1.0), offsets=(0.5, 0.0))
    assert axis.to_joints(0.2, 0.1) == pytest.approx((0.3, -0.1))
    assert axis.from_joints(*axis.to_joints(0.2, 0.1)) == pytest.approx((0.2, 0.1))
    assert axis.rates_to_joints(0.2, 0.1) == pytest.approx((-0.2, -0.1))
    unit = UnitSettings(NAMES, mapping=axis)
    joints = unit_command(Command(CommandMode.VELOCITY, pan_rate=0.2, tilt_rate=0.1), None, unit)
    assert joints.velocities == pytest.approx([-0.2, -0.1])
    with pytest.raises(ValueError, match="1 or -1"):
        JointMapping(signs=(2.0, 1.0))


def test_commanded_motion_integrates_the_rates_between_two_stamps():
    motion = CommandedMotion()
    s = 10**9
    motion.add(1 * s, 0.1, 0.0)
    motion.add(2 * s, 0.0, -0.2)
    motion.add(3 * s, 0.0, 0.0)
    assert motion.travel(0, s) == (0.0, 0.0)  # nothing commanded before the first command
    assert motion.travel(s // 2 * 3, 5 * s // 2) == pytest.approx((0.05, -0.1))
    assert motion.travel(3 * s, 9 * s) == (0.0, 0.0)
    assert motion.rate_at(2 * s + 1) == (0.0, -0.2) and motion.rate_at(s - 1) is None
    motion.add(s // 2, 1.0, 1.0)  # time jumped back: the old epoch's commands go
    assert motion.travel(0, 9 * s) == pytest.approx((8.5, 8.5))


def test_velocity_only_turns_a_direct_move_into_a_rate_toward_its_goal():
    from tracker_ptz_sim.control.unit_joints import velocity_only

    axis = JointMapping(signs=(-1.0, -1.0))
    direct = Command(CommandMode.POSITION, pan=0.5, tilt=0.1)
    assert velocity_only(direct, POSE, axis, 2.0, 1.0) == pytest.approx((-0.6, -0.4))
    assert velocity_only(direct, None, axis, 2.0, 1.0) == (0.0, 0.0)  # pose unknown: stay
    far = Command(CommandMode.POSITION, pan=3.0, tilt=-0.1)
    assert velocity_only(far, POSE, axis, 2.0, 1.0)[0] == -1.0  # within max_rate
    turning = Command(CommandMode.VELOCITY, pan_rate=0.3, tilt_rate=0.1)
    assert velocity_only(turning, POSE, axis, 2.0, 1.0) == pytest.approx((-0.3, -0.1))
    assert velocity_only(Command(CommandMode.HOLD), POSE, axis, 2.0, 1.0) == (0.0, 0.0)
