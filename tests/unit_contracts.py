"""The message contracts of real pan-tilt drivers, as their sources document them, to check the
suite's commands against."""

from __future__ import annotations

import math

from tracker_ptz_sim.control.unit_joints import JointCommand, UnitSettings


def flir_ptu_contract_problem(joints: JointCommand, unit: UnitSettings) -> str | None:
    """What the FLIR PTU driver (flir_ptu_driver, `cmd`) would refuse or misread in a command, by
    its documented contract: exactly two positions [pan, tilt] by index (else the command is
    dropped with "wrong number of position elements"), exactly two velocities used as speeds (else
    the default speed, 0: the unit does not move), speeds within the unit's speed range (the PTU
    refuses others) and positions within its position limits."""
    if len(joints.positions) != 2:
        return f"{len(joints.positions)} positions, the driver needs exactly 2"
    if len(joints.velocities) != 2:
        return f"{len(joints.velocities)} velocities: the driver would move at its default speed 0"
    if not all(math.isfinite(v) for v in (*joints.positions, *joints.velocities)):
        return f"not finite: {joints.positions}, {joints.velocities}"
    low, high = unit.speed_limits
    if not all(low <= speed <= high for speed in joints.velocities):
        return f"speeds {joints.velocities} outside [{low}, {high}] rad/s"
    pan, tilt = unit.mapping.from_joints(*joints.positions)
    if not unit.pan_limits[0] <= pan <= unit.pan_limits[1]:
        return f"pan {pan} outside {unit.pan_limits}"
    if not unit.tilt_limits[0] <= tilt <= unit.tilt_limits[1]:
        return f"tilt {tilt} outside {unit.tilt_limits}"
    return None
