"""Simulated pan-tilt-zoom camera: a window moving over the recorded scene (no rclpy).

Seed 000 §4: the whole recorded frame is the surveillance area; the camera sees a window of it.
Pan/tilt map to the window centre through the focal length (`tracker_msgs_py.geometry`, REP-103
signs: pan positive = left, tilt positive = down). The window always stays inside the scene, as the
seed clamps it: the reachable pan/tilt range shrinks as the window grows (zoom out).

Servo dynamics per axis: rate and acceleration limits, a command latency (in seconds and in
frames: a command answering frame n acts from frame n + `command_delay_frames` on, which lets a
lockstep replay keep that many frames in flight and stay deterministic), position commands with a
deceleration profile that stops on target, velocity commands with a watchdog (no command for
`velocity_timeout` -> stop, as real pan-tilt units do). `servo="instant"` reproduces the seed's
jumping window. Zoom scales the window by 1/zoom (from `min_zoom`, which may be below 1 to see
more than the zoom-1 view, up to the whole scene, to `max_zoom`); the output image keeps its size.

Everything advances on the recording's stamps, so a replay is deterministic. At zoom 1 the window
snaps to whole scene pixels and the reported angles are those of the window shown, so every view is
an exact slice of its scene frame and the angles map to its rectangle exactly.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace

import cv2
import numpy as np

from tracker_detect.pinhole import pinhole_view
from tracker_msgs_py.geometry import Rect, SceneGeometry
from tracker_msgs_py.params import check_config, param

INTEGRATION_STEP_S = 0.005  # servo dynamics are integrated in steps of at most this
MIN_VIEW_SIDE = 8  # px: the smallest camera image the model makes (a scene must allow it)
MAX_COMMAND_DELAY_FRAMES = 32


@dataclass(frozen=True)
class PtzConfig:
    view_height_fraction: float = param(
        110 / 240,
        "window height / scene height at zoom 1 (seed: 110/240)",
        min=0.05,
        max=1.0,
    )
    view_aspect: float = param(1.0, "window width / height (seed: square)", min=0.1, max=10.0)
    focal_length: float = param(
        0.0, "scene px per rad (0 = window width / view_fov)", min=0.0, max=1e6
    )
    view_fov: float = param(
        0.6, "horizontal field of view at zoom 1", min=0.01, max=3.0, unit="rad"
    )
    servo: str = param(
        "dynamic",
        "dynamic: rate/acceleration-limited servos; instant: the seed's jumps",
        choices=("dynamic", "instant"),
    )
    max_speed: float = param(1.5, "servo rate limit per axis", min=0.001, max=100.0, unit="rad/s")
    max_acceleration: float = param(
        8.0, "servo acceleration limit", min=0.001, max=1e4, unit="rad/s^2"
    )
    command_latency: float = param(0.0, "delay before a command acts", min=0.0, max=10.0, unit="s")
    command_delay_frames: int = param(
        1,
        "a command answering image n acts from image n + this on; lockstep: as many frames may "
        "be in flight (video_source frames_in_flight)",
        min=1,
        max=MAX_COMMAND_DELAY_FRAMES,
        read_only=True,
    )
    velocity_timeout: float = param(0.5, "velocity command watchdog", min=0.01, max=60.0, unit="s")
    max_zoom: float = param(4.0, "largest zoom factor", min=1.0, max=100.0)
    min_zoom: float = param(
        1.0,
        "smallest zoom factor; below 1 the view widens beyond the zoom-1 window (up to the scene)",
        min=0.05,
        max=1.0,
    )
    initial_pan: float = param(
        0.0, "pan at start", min=-math.pi, max=math.pi, unit="rad", read_only=True
    )
    initial_tilt: float = param(
        0.0, "tilt at start", min=-math.pi, max=math.pi, unit="rad", read_only=True
    )

    def problems(self) -> list[str]:
        return []


@dataclass(frozen=True)
class PtzCommand:
    """A command as the model sees it: `stamp` is the scene time it was issued at [s]."""

    stamp: float
    mode: str  # "position", "velocity" or "hold"
    pan: float = 0.0
    tilt: float = 0.0
    pan_rate: float = 0.0
    tilt_rate: float = 0.0
    zoom: float = 0.0  # 0 or NaN: keep
    speeds: tuple[float, float] | None = None  # position: [pan, tilt] rad/s to go at (a PTU's)


@dataclass(frozen=True)
class PtzSnapshot:
    """The camera at one instant: what the PtzState/JointState messages report."""

    time: float
    pan: float
    tilt: float
    pan_rate: float
    tilt_rate: float
    zoom: float
    window: Rect  # scene px, the part of the scene the view shows
    moving: bool


@dataclass
class _Axis:
    position: float
    rate: float = 0.0


class PtzCameraModel:
    """The camera over a scene of `width` x `height` px; `advance(t)` then `render(frame)`."""

    def __init__(self, config: PtzConfig, width: int, height: int) -> None:
        check_config(config)
        self.config = config
        self.width, self.height = width, height
        self.base_size = view_size(config, width, height)
        focal = config.focal_length or self.base_size[0] / config.view_fov
        self.geometry = SceneGeometry(width, height, focal)
        self.zoom = 1.0
        self.time: float | None = None
        self.pan = _Axis(config.initial_pan)
        self.tilt = _Axis(config.initial_tilt)
        self._pending: deque[tuple[int, PtzCommand]] = deque()  # (frame it may act from, command)
        self._active: PtzCommand | None = None
        self._active_since = 0.0
        self._frame_times: deque[float] = deque(maxlen=MAX_COMMAND_DELAY_FRAMES + 1)
        self._frame = -1  # index of the newest frame advanced to
        self._clamp_axes()

    # --- commands -------------------------------------------------------------------------------

    def command(self, command: PtzCommand) -> None:
        """Queue a command; it acts from `command.stamp + command_latency` on, and not before the
        frame `command_delay_frames` after the one it answers."""
        values = (command.pan, command.tilt, command.pan_rate, command.tilt_rate)
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f"non-finite pan-tilt command {values}")
        if command.mode not in ("position", "velocity", "hold"):
            raise ValueError(f"unknown command mode '{command.mode}'")
        due = self._answered_frame(command.stamp) + self.config.command_delay_frames
        self._pending.append((due, command))

    def _answered_frame(self, stamp: float) -> int:
        """Index of the newest frame at or before `stamp` (-1 before the first)."""
        index = self._frame
        for frame_time in reversed(self._frame_times):
            if frame_time <= stamp + 1e-12:
                return index
            index -= 1
        return index

    # --- time -----------------------------------------------------------------------------------

    def restart_clock(self, t: float) -> None:
        """A new time base from `t` [s] on (a replay restarted, so time jumped back): pending and
        active commands belong to the old one and are dropped; the servos stop where they are."""
        self.time = t
        self._pending.clear()
        self._frame_times.clear()
        self._frame = -1
        self._active = None
        self.pan.rate = self.tilt.rate = 0.0

    def advance(self, t: float) -> PtzSnapshot:
        """Move the servos to the time `t` [s] of the next frame (never backwards) and return the
        camera's state."""
        if self.time is None:
            self.time = t
        if not self._frame_times or t > self._frame_times[-1]:
            self._frame_times.append(t)
            self._frame += 1
        while self.time < t:
            due = self._next_activation()
            step_end = min(t, self.time + INTEGRATION_STEP_S, due if due > self.time else t)
            self._activate_due(self.time)
            self._integrate(step_end - self.time)
            self.time = step_end
        self._activate_due(self.time)
        if self.config.servo == "instant":
            self._integrate(0.0)
        return self.snapshot()

    def _next_activation(self) -> float:
        if not self._pending or self._pending[0][0] > self._frame:
            return math.inf
        return self._pending[0][1].stamp + self.config.command_latency

    def _activate_due(self, now: float) -> None:
        while self._pending and self._next_activation() <= now + 1e-12:
            command = self._pending.popleft()[1]
            self._active_since = now
            if command.zoom and math.isfinite(command.zoom):
                self.zoom = min(max(command.zoom, self.config.min_zoom), self.config.max_zoom)
            self._active = command if command.mode != "hold" else None
            if command.mode == "hold" or self.config.servo == "instant":
                self.pan.rate = self.tilt.rate = 0.0

    def _integrate(self, dt: float) -> None:
        command = self._active
        if command is not None and self._velocity_expired(command):
            command = self._active = None  # watchdog: no fresh velocity command -> stop
        if self.config.servo == "instant":
            self._integrate_instant(command, dt)
        else:
            for axis, target, rate, speed in self._axis_goals(command):
                _servo_step(axis, target, rate, speed, self.config.max_acceleration, dt)
        self._clamp_axes()

    def _velocity_expired(self, command: PtzCommand) -> bool:
        """The unit's watchdog counts from when the command reached the servos."""
        return (
            command.mode == "velocity"
            and self.time is not None
            and self.time - self._active_since >= self.config.velocity_timeout
        )

    def _integrate_instant(self, command: PtzCommand | None, dt: float) -> None:
        if command is None:
            return
        if command.mode == "position":
            self.pan.position, self.tilt.position = command.pan, command.tilt
        else:
            self.pan.rate, self.tilt.rate = command.pan_rate, command.tilt_rate
            self.pan.position += command.pan_rate * dt
            self.tilt.position += command.tilt_rate * dt

    def _axis_goals(
        self, command: PtzCommand | None
    ) -> list[tuple[_Axis, float | None, float, float]]:
        """Per axis: the position to reach (None in velocity mode), the rate to hold and the
        speed limit (the unit's, or the command's lower one)."""
        top = self.config.max_speed
        if command is None:
            return [(self.pan, None, 0.0, top), (self.tilt, None, 0.0, top)]
        if command.mode == "position":
            pan_speed, tilt_speed = command.speeds or (top, top)
            return [
                (self.pan, command.pan, 0.0, min(top, pan_speed)),
                (self.tilt, command.tilt, 0.0, min(top, tilt_speed)),
            ]
        return [
            (self.pan, None, command.pan_rate, top),
            (self.tilt, None, command.tilt_rate, top),
        ]

    # --- geometry -------------------------------------------------------------------------------

    def window_size(self) -> tuple[int, int]:
        """(width, height) px of the window at the current zoom: the zoom-1 view / zoom, at most
        as large as the scene (the aspect kept)."""
        base_w, base_h = self.base_size
        scale = min(1.0 / self.zoom, self.width / base_w, self.height / base_h)
        return max(2, int(round(base_w * scale))), max(2, int(round(base_h * scale)))

    def limits(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """(pan_min, pan_max), (tilt_min, tilt_max) keeping the window inside the scene [rad]."""
        w, h = self.window_size()
        f = self.geometry.focal_length
        cx, cy = self.geometry.center
        pan_span = (cx - w / 2.0) / f
        tilt_span = (cy - h / 2.0) / f
        return (-pan_span, pan_span), (-tilt_span, tilt_span)

    def _clamp_axes(self) -> None:
        (pan_lo, pan_hi), (tilt_lo, tilt_hi) = self.limits()
        for axis, lo, hi in ((self.pan, pan_lo, pan_hi), (self.tilt, tilt_lo, tilt_hi)):
            if axis.position < lo or axis.position > hi:
                axis.position = min(max(axis.position, lo), hi)
                axis.rate = 0.0

    def window(self) -> Rect:
        """The scene rectangle shown: centred on the line of sight, snapped to whole pixels."""
        w, h = self.window_size()
        cx, cy = self.geometry.angles_to_pixel(self.pan.position, self.tilt.position)
        x0 = min(max(int(round(cx - w / 2.0)), 0), self.width - w)
        y0 = min(max(int(round(cy - h / 2.0)), 0), self.height - h)
        return Rect(float(x0), float(y0), float(w), float(h))

    def snapshot(self) -> PtzSnapshot:
        window = self.window()
        pan, tilt = self.geometry.pixel_to_angles(*window.center)
        moving = abs(self.pan.rate) > 1e-9 or abs(self.tilt.rate) > 1e-9
        return PtzSnapshot(
            self.time or 0.0, pan, tilt, self.pan.rate, self.tilt.rate, self.zoom, window, moving
        )

    def output_size(self) -> tuple[int, int]:
        """(width, height) of the camera image: the window's size at zoom 1, whatever the zoom."""
        return self.base_size

    def pinhole_span(self, window: Rect) -> tuple[float, float]:
        """Width and height [scene px] a pinhole camera with `intrinsics()` sees of `window`:
        its edge rays, 2 f atan(w / 2f), about 3 % less than w at a 34 degree field of view."""
        focal = self.geometry.focal_length
        return (
            2.0 * focal * math.atan(window.width / (2.0 * focal)),
            2.0 * focal * math.atan(window.height / (2.0 * focal)),
        )

    def intrinsics(self) -> tuple[float, float, float, float]:
        """fx, fy, cx, cy of the camera image (px per rad at the image centre, principal point)."""
        out_w, out_h = self.output_size()
        w, _ = self.window_size()
        focal = self.geometry.focal_length * out_w / w
        return focal, focal, out_w / 2.0, out_h / 2.0

    def render(
        self, scene: np.ndarray, window: Rect | None = None, pinhole: bool = False
    ) -> np.ndarray:
        """The camera image of `scene` for `window` (default: the current one): the window
        resampled linearly, or with `pinhole` the image a real (pinhole) camera with the
        `intrinsics()` takes there, which sees the narrower `pinhole_span()` of it."""
        if scene.shape[0] != self.height or scene.shape[1] != self.width:
            raise ValueError(
                f"scene frame is {scene.shape[1]}x{scene.shape[0]}, the camera was set up for "
                f"{self.width}x{self.height}"
            )
        window = window or self.window()
        x0, y0 = int(window.x), int(window.y)
        view = scene[y0 : y0 + int(window.height), x0 : x0 + int(window.width)]
        out_w, out_h = self.output_size()
        if pinhole:
            span = self.pinhole_span(window)
            return pinhole_view(view, (out_w, out_h), span, self.geometry.focal_length)
        if view.shape[1] == out_w and view.shape[0] == out_h:
            return np.ascontiguousarray(view)
        return cv2.resize(view, (out_w, out_h), interpolation=cv2.INTER_LINEAR)

    def reconfigure(self, config: PtzConfig) -> None:
        """Apply new limits/dynamics; the pose is kept (then clamped to the new window)."""
        check_config(config)
        geometry_changed = (
            config.view_height_fraction != self.config.view_height_fraction
            or config.view_aspect != self.config.view_aspect
            or config.focal_length != self.config.focal_length
            or config.view_fov != self.config.view_fov
        )
        if geometry_changed:
            rebuilt = PtzCameraModel(
                replace(config, initial_pan=self.pan.position, initial_tilt=self.tilt.position),
                self.width,
                self.height,
            )
            self.base_size, self.geometry = rebuilt.base_size, rebuilt.geometry
        self.config = config
        self.zoom = min(max(self.zoom, config.min_zoom), config.max_zoom)
        self._clamp_axes()


def view_size(config: PtzConfig, width: int, height: int) -> tuple[int, int]:
    """(width, height) px of the window at zoom 1 on a `width` x `height` scene.

    Raises ValueError when the scene cannot hold a window of MIN_VIEW_SIDE px on each side.
    """
    base_h = min(height, int(round(config.view_height_fraction * height)))
    base_w = min(width, int(round(base_h * config.view_aspect)))
    if min(base_w, base_h) < MIN_VIEW_SIDE:
        raise ValueError(
            f"a {width}x{height} px scene is too small: its camera view would be {base_w}x{base_h}"
            f" px (at least {MIN_VIEW_SIDE} px a side needed)"
        )
    return base_w, base_h


def _servo_step(
    axis: _Axis,
    target: float | None,
    hold_rate: float,
    max_speed: float,
    max_accel: float,
    dt: float,
) -> None:
    """One integration step of an axis with rate and acceleration limits.

    Position goal: the fastest rate that can still stop on target (v = sqrt(2 a d)), capped at the
    speed limit. Rate goal: `hold_rate`, capped. The rate then moves toward the wanted rate by at
    most a * dt, and the position integrates the mean rate over the step.
    """
    if dt <= 0:
        return
    if target is not None:
        error = target - axis.position
        wanted = math.copysign(min(max_speed, math.sqrt(2.0 * max_accel * abs(error))), error)
        if abs(error) <= max_accel * dt * dt and abs(axis.rate) <= max_accel * dt:
            axis.position, axis.rate = target, 0.0  # arrived: settle exactly
            return
        # Do not overshoot within the step.
        wanted = math.copysign(min(abs(wanted), abs(error) / dt), error)
    else:
        wanted = max(-max_speed, min(max_speed, hold_rate))
    change = max(-max_accel * dt, min(max_accel * dt, wanted - axis.rate))
    new_rate = axis.rate + change
    axis.position += 0.5 * (axis.rate + new_rate) * dt
    axis.rate = new_rate
