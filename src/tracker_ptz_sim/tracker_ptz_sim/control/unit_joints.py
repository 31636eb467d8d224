"""The suite's pan-tilt commands and poses in a real unit's joints, as its driver takes them (no
rclpy).

The suite works in REP-103 angles of the camera's line of sight: pan + = left, tilt + = down, 0 =
the unit's home. A unit's joints may count the other way or from another zero (Axis cameras count
pan clockwise and tilt + = up), so `JointMapping` maps one to the other:
joint = sign · angle + offset, and back.

Drivers differ in what a command is (`CommandStyle`):

- `velocity_or_position`: a JointState with velocities for servo moves and holds, positions for
  direct moves and the search; NaN marks what is not commanded. For drivers that take per-joint
  velocity commands (the suite's own camera, a ros2_control velocity controller behind a relay).
- `positions_with_speeds`: what the FLIR PTU driver's `cmd` takes: always exactly two positions
  [pan, tilt] (by index: the driver ignores names) and two speeds [rad/s, >= 0] within the unit's
  speed range; a command without speeds moves at the driver's default speed, 0. A rate becomes a
  goal `lead` seconds ahead of the pose of the image it answers, approached at |rate| (a unit that
  stops hearing commands stops within `lead`, as a velocity watchdog would stop it); a hold is a
  goal at that pose; a direct move goes at the highest speed.

Cameras whose driver takes rates alone (the Axis driver's `cmd/velocity`: pan, tilt [rad/s] and
a zoom speed) get `velocity_only`: a direct move or search becomes a rate toward its goal.

`CommandedMotion` remembers the commanded rates, so a pose between sparse joint states (an Axis
driver publishes them at 1 Hz, with zero velocities) can be carried forward by what the unit was
told to do.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from enum import Enum
from typing import Any

from tracker_msgs_py.params import param, specs_of
from tracker_ptz_sim.control.controller import CameraPose, Command, CommandMode


class CommandStyle(Enum):
    VELOCITY_OR_POSITION = "velocity_or_position"
    POSITIONS_WITH_SPEEDS = "positions_with_speeds"


@dataclass(frozen=True)
class JointMapping:
    """joint = sign · angle + offset per axis (pan, tilt); signs are +1 or -1."""

    signs: tuple[float, float] = (1.0, 1.0)
    offsets: tuple[float, float] = (0.0, 0.0)

    def __post_init__(self) -> None:
        if any(sign not in (1.0, -1.0) for sign in self.signs):
            raise ValueError(f"joint signs must be 1 or -1, got {list(self.signs)}")
        if not all(math.isfinite(offset) for offset in self.offsets):
            raise ValueError(f"joint offsets must be finite, got {list(self.offsets)}")

    def to_joints(self, pan: float, tilt: float) -> tuple[float, float]:
        return (
            self.signs[0] * pan + self.offsets[0],
            self.signs[1] * tilt + self.offsets[1],
        )

    def from_joints(self, pan_joint: float, tilt_joint: float) -> tuple[float, float]:
        return (
            self.signs[0] * (pan_joint - self.offsets[0]),
            self.signs[1] * (tilt_joint - self.offsets[1]),
        )

    def rates_to_joints(self, pan_rate: float, tilt_rate: float) -> tuple[float, float]:
        """Rates carry the sign, not the offset (the same map both ways: a sign is its inverse)."""
        return self.signs[0] * pan_rate, self.signs[1] * tilt_rate


def _signs_problem(value: Any) -> str | None:
    if len(value) != 2 or any(sign not in (1.0, -1.0) for sign in value):
        return f"joint_signs needs two values, each 1 or -1 (pan, tilt), got {list(value)}"
    return None


@dataclass(frozen=True)
class JointMappingConfig:
    """The mapping's parameters, declared alike by every node that meets the unit's joints (each
    nests this with `params_of`)."""

    joint_signs: tuple[float, ...] = param(
        [1.0, 1.0],
        "[pan, tilt] joint = sign * REP-103 angle + offset: -1 where the unit counts the other "
        "way (Axis: pan clockwise, tilt + = up)",
        validator=_signs_problem,
        read_only=True,
    )
    joint_offsets: tuple[float, ...] = param(
        [0.0, 0.0],
        "[pan, tilt] joint position when the camera looks along the suite's pan/tilt 0",
        unit="rad",
        validator=lambda v: None if len(v) == 2 else "joint_offsets needs two values (pan, tilt)",
        read_only=True,
    )

    def problems(self) -> list[str]:
        return []

    def mapping(self) -> JointMapping:
        """The mapping these parameters describe."""
        signs, offsets = self.joint_signs, self.joint_offsets
        return JointMapping(
            (float(signs[0]), float(signs[1])), (float(offsets[0]), float(offsets[1]))
        )


#: The mapping's parameters (`JointMappingConfig`'s), for code that wants the specs.
JOINT_MAPPING_PARAMETERS = list(specs_of(JointMappingConfig))


@dataclass(frozen=True)
class JointCommand:
    """A JointState command's arrays; NaN = not commanded, empty = not sent."""

    names: list[str]
    positions: list[float]
    velocities: list[float]


@dataclass(frozen=True)
class UnitSettings:
    """How commands reach one unit."""

    names: tuple[str, str] = ("pan_joint", "tilt_joint")
    style: CommandStyle = CommandStyle.VELOCITY_OR_POSITION
    mapping: JointMapping = JointMapping()
    zoom_joint: str = ""  # commanded by position when the zoom changes ('' = none)
    speed_limits: tuple[float, float] = (0.0, 1.0)  # rad/s the unit's speeds may take
    lead: float = 0.5  # s: how far ahead a rate's goal lies (positions_with_speeds)
    pan_limits: tuple[float, float] = (-math.pi, math.pi)  # REP-103 angles a goal is kept within
    tilt_limits: tuple[float, float] = (-math.pi / 2, math.pi / 2)

    def __post_init__(self) -> None:
        low, high = self.speed_limits
        if not 0.0 <= low < high:
            raise ValueError(f"speed limits must be 0 <= min < max, got {list(self.speed_limits)}")
        if self.style is CommandStyle.POSITIONS_WITH_SPEEDS and self.zoom_joint:
            raise ValueError(
                "positions_with_speeds sends exactly two positions (the FLIR PTU driver's cmd): "
                "set zoom_joint to ''"
            )


def unit_command(command: Command, pose: CameraPose | None, unit: UnitSettings) -> JointCommand:
    """The command in the unit's joints and style. `pose` is where the camera looked in the image
    the command answers (None: unknown, then a positions_with_speeds rate or hold is not sent:
    empty arrays)."""
    if unit.style is CommandStyle.POSITIONS_WITH_SPEEDS:
        return _positions_with_speeds(command, pose, unit)
    return _velocity_or_position(command, unit)


def _velocity_or_position(command: Command, unit: UnitSettings) -> JointCommand:
    names = list(unit.names)
    if command.mode is CommandMode.POSITION:
        positions = list(unit.mapping.to_joints(command.pan, command.tilt))
        velocities: list[float] = []
    else:
        positions = []
        velocities = list(unit.mapping.rates_to_joints(command.pan_rate, command.tilt_rate))
    if unit.zoom_joint and command.zoom > 0.0:
        names.append(unit.zoom_joint)
        if command.mode is CommandMode.POSITION:
            positions.append(command.zoom)
        else:
            positions = [math.nan, math.nan, command.zoom]
            velocities.append(math.nan)
    return JointCommand(names, positions, velocities)


def _positions_with_speeds(
    command: Command, pose: CameraPose | None, unit: UnitSettings
) -> JointCommand:
    low, high = unit.speed_limits
    if command.mode is CommandMode.POSITION:
        goal = (command.pan, command.tilt)
        speeds = (high, high)
    elif pose is None:
        return JointCommand(list(unit.names), [], [])
    else:
        rates = (command.pan_rate, command.tilt_rate)
        if command.mode is CommandMode.HOLD:
            rates = (0.0, 0.0)
        goal = (pose.pan + rates[0] * unit.lead, pose.tilt + rates[1] * unit.lead)
        speeds = (min(max(abs(rates[0]), low), high), min(max(abs(rates[1]), low), high))
    pan = min(max(goal[0], unit.pan_limits[0]), unit.pan_limits[1])
    tilt = min(max(goal[1], unit.tilt_limits[0]), unit.tilt_limits[1])
    return JointCommand(list(unit.names), list(unit.mapping.to_joints(pan, tilt)), list(speeds))


def velocity_only(
    command: Command, pose: CameraPose | None, mapping: JointMapping, gain: float, max_rate: float
) -> tuple[float, float]:
    """The command as joint rates: its rates, 0 for a hold, and for a direct move
    `gain` × (goal − pose) within ±`max_rate` (0 while the pose is unknown)."""
    if command.mode is CommandMode.VELOCITY:
        rates = (command.pan_rate, command.tilt_rate)
    elif command.mode is CommandMode.POSITION and pose is not None:
        rates = (gain * (command.pan - pose.pan), gain * (command.tilt - pose.tilt))
    else:
        rates = (0.0, 0.0)
    pan, tilt = (min(max(rate, -max_rate), max_rate) for rate in rates)
    return mapping.rates_to_joints(pan, tilt)


class CommandedMotion:
    """The pan and tilt rates the unit was commanded, by stamp, to carry a pose forward between
    joint states: a command holds from its stamp until the next one."""

    def __init__(self, capacity: int = 256) -> None:
        self.capacity = capacity
        self._stamps: list[int] = []
        self._rates: list[tuple[float, float]] = []

    def add(self, stamp_ns: int, pan_rate: float, tilt_rate: float) -> None:
        """A velocity command (REP-103 rates; a position command or hold: rates 0)."""
        if self._stamps and stamp_ns < self._stamps[-1]:
            self.clear()  # time jumped back: a new epoch
        if self._stamps and stamp_ns == self._stamps[-1]:
            self._rates[-1] = (pan_rate, tilt_rate)
            return
        self._stamps.append(stamp_ns)
        self._rates.append((pan_rate, tilt_rate))
        if len(self._stamps) > self.capacity:
            del self._stamps[0], self._rates[0]

    def clear(self) -> None:
        self._stamps.clear()
        self._rates.clear()

    def rate_at(self, stamp_ns: int) -> tuple[float, float] | None:
        """The rates commanded at `stamp_ns` (None before the first command)."""
        index = bisect.bisect_right(self._stamps, stamp_ns) - 1
        return self._rates[index] if index >= 0 else None

    def travel(self, start_ns: int, end_ns: int) -> tuple[float, float]:
        """How far the commands moved pan and tilt [rad] from `start_ns` to `end_ns` (0 before the
        first command, or when `end_ns` is not after `start_ns`)."""
        if end_ns <= start_ns or not self._stamps:
            return 0.0, 0.0
        pan = tilt = 0.0
        index = max(bisect.bisect_right(self._stamps, start_ns) - 1, 0)
        for k in range(index, bisect.bisect_left(self._stamps, end_ns)):
            begin = max(self._stamps[k], start_ns)
            finish = min(self._stamps[k + 1], end_ns) if k + 1 < len(self._stamps) else end_ns
            if finish <= begin:
                continue
            seconds = (finish - begin) * 1e-9
            pan += self._rates[k][0] * seconds
            tilt += self._rates[k][1] * seconds
        return pan, tilt
