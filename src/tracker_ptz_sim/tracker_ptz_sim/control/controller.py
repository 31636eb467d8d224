"""Pan-tilt controller: keeps the selected target in view (no rclpy).

Works in the pan-tilt angles of REP-103 (pan positive = left, tilt positive = down). The target
arrives in scene pixels; because the scene mapping is linear (`tracker_msgs_py.geometry`), an offset
of d px from the view centre is an angle of d / f, so only the focal length is needed.

States:
- TRACK: a target is locked. `direct` mode (seed 000) jumps the line of sight to the target's
  estimate; `servo` mode runs a PI controller on the angular error with a dead zone, velocity
  feed-forward from the track, and aims at the target's predicted position (latency compensation).
- SCAN: the target was lost; oscillate around its last position for `lost_scan_time` s.
- HOME: go to the home preset and dwell there for `home_dwell_time` s.
- SEARCH: nothing tracked; sweep horizontally, reversing at the pan limits (seed 000), or visit a
  list of preset poses in turn.

`hold` mode is a fixed camera (seed 004's static camera watching many objects): every step answers
with HOLD, whatever is tracked, so the unit stays where it is and never zooms; the commands still
acknowledge each image, as a lockstep replay needs.

Zoom (`zoom_control`): while tracking, the target's box should fill between `fill_low` and
`fill_high` of the view's height; outside that band the zoom moves towards `fill_target`
(zoom out when the target no longer fits, back in when it is small, up to `max_zoom`: a target
seen only in part looks small too), by at most `zoom_step` per command so the detector's
background keeps up, until it fills `fill_target`. Without a target the zoom returns to `home_zoom`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from enum import Enum
from typing import Any

from tracker_msgs_py.params import check_config, config_from_params, param


class ControlState(Enum):
    SEARCH = "search"
    TRACK = "track"
    SCAN = "scan"
    HOME = "home"


class CommandMode(Enum):
    POSITION = "position"
    VELOCITY = "velocity"
    HOLD = "hold"


@dataclass(frozen=True)
class Command:
    """What to send to the pan-tilt unit: angles [rad] for POSITION, rates [rad/s] for VELOCITY."""

    mode: CommandMode
    pan: float = 0.0
    tilt: float = 0.0
    pan_rate: float = 0.0
    tilt_rate: float = 0.0
    zoom: float = 0.0  # magnification to move to; 0 keeps the current one


@dataclass(frozen=True)
class CameraPose:
    """Where the camera looks now: line-of-sight angles and the view centre in scene pixels."""

    pan: float
    tilt: float
    center_x: float
    center_y: float
    focal_length: float  # scene px per radian
    zoom: float = 1.0
    view_height: float = math.nan  # scene px, the height of the part of the scene in view


@dataclass(frozen=True)
class TargetEstimate:
    """The tracker's target in scene pixels: position, velocity [px/s] and predicted position."""

    x: float
    y: float
    vx: float
    vy: float
    predicted_x: float
    predicted_y: float
    height: float = math.nan  # scene px, the target's box height


@dataclass(frozen=True)
class ControllerConfig:
    mode: str = "servo"  # "direct", "servo" or "hold" (a fixed camera: never moves)
    kp: float = 1.5  # 1/s: rate per radian of error
    ki: float = 0.3  # 1/s^2
    dead_zone: float = 0.01  # rad: errors below this are not corrected
    max_rate: float = 1.5  # rad/s
    feed_forward: bool = True  # add the target's angular velocity to the command
    aim_at_prediction: bool = True  # aim at the tracker's predicted position (latency compensation)
    # s: the unit's delay from a command to its motion (a movement calibration measures it): the
    # aim leads the target by this much beyond the tracker's prediction
    unit_latency: float = 0.0
    search: str = "sweep"  # "sweep", "presets" or "none"
    sweep_rate: float = 0.25  # rad/s
    # rad: the unit's range; no command leaves it, the sweep reverses at it (and on a stall)
    pan_limits: tuple[float, float] = (-math.pi, math.pi)
    tilt_limits: tuple[float, float] = (-math.pi / 2, math.pi / 2)
    presets: tuple[tuple[float, float], ...] = ()  # (pan, tilt) rad, for "presets"
    preset_dwell_time: float = 3.0  # s at each search preset
    home: tuple[float, float] = (0.0, 0.0)  # (pan, tilt) rad
    lost_scan_time: float = 3.0  # s scanning the last region after a loss
    scan_amplitude: float = 0.15  # rad, half-width of the scan around the last position
    scan_period: float = 2.0  # s for one scan oscillation
    home_dwell_time: float = 5.0  # s at home before searching again
    zoom_control: bool = False  # keep the target's height within [fill_low, fill_high] of the view
    fill_low: float = 0.2  # target height / view height below which the camera zooms in
    fill_high: float = 0.8  # ... above which it zooms out
    fill_target: float = 0.5  # ... the zoom aims at
    zoom_step: float = 1.25  # largest zoom change per command, as a ratio
    home_zoom: float = 1.0  # zoom without a target
    max_zoom: float = 1.0  # the controller zooms in no further (a partly seen target looks small)

    def problems(self) -> list[str]:
        """Why this configuration is unusable (empty: usable)."""
        found = []
        if self.mode not in ("direct", "servo", "hold"):
            found.append(f"mode must be direct, servo or hold, got '{self.mode}'")
        if self.search not in ("sweep", "presets", "none"):
            found.append(f"search must be sweep, presets or none, got '{self.search}'")
        if self.search == "presets" and not self.presets:
            found.append("search 'presets' needs at least one preset pose")
        if self.pan_limits[0] >= self.pan_limits[1]:
            found.append(f"pan_limits must be increasing, got {self.pan_limits}")
        if self.tilt_limits[0] >= self.tilt_limits[1]:
            found.append(f"tilt_limits must be increasing, got {self.tilt_limits}")
        if not 0.0 <= self.fill_low < self.fill_target < self.fill_high:
            found.append(
                "need 0 <= fill_low < fill_target < fill_high, got "
                f"{self.fill_low}, {self.fill_target}, {self.fill_high}"
            )
        if not self.zoom_step > 1.0:
            found.append(f"zoom_step must be > 1, got {self.zoom_step}")
        if not 0.0 < self.home_zoom <= self.max_zoom:
            found.append(f"need 0 < home_zoom <= max_zoom, got {self.home_zoom}, {self.max_zoom}")
        return found


_DEFAULTS = ControllerConfig()


@dataclass(frozen=True)
class ControllerParams:
    """The controller's parameters as the ptz_controller node declares them (and the in-process
    pipeline reads them): the limits and home are [a, b] lists, presets a flat
    [pan1, tilt1, ...] list; `controller_config()` is the ControllerConfig they describe."""

    mode: str = param(
        _DEFAULTS.mode,
        "direct: jump to the target (seed 000); servo: PI velocity control; hold: a fixed "
        "camera (every target answered with HOLD)",
        choices=("direct", "servo", "hold"),
    )
    kp: float = param(_DEFAULTS.kp, "servo proportional gain", min=0.0, max=50.0, unit="1/s")
    ki: float = param(_DEFAULTS.ki, "servo integral gain", min=0.0, max=50.0, unit="1/s^2")
    dead_zone: float = param(
        _DEFAULTS.dead_zone, "angular error left uncorrected", min=0.0, max=0.5, unit="rad"
    )
    max_rate: float = param(
        _DEFAULTS.max_rate, "largest commanded rate", min=0.01, max=10.0, unit="rad/s"
    )
    feed_forward: bool = param(_DEFAULTS.feed_forward, "add the target's angular velocity")
    aim_at_prediction: bool = param(
        _DEFAULTS.aim_at_prediction,
        "aim at the target's predicted position (latency compensation)",
    )
    unit_latency: float = param(
        _DEFAULTS.unit_latency,
        "the unit's delay from a command to its motion: the aim leads the target by this much "
        "beyond the tracker's prediction; set from ptz/unit_latency when the unit's driver "
        "measures it (onvif_ptz calibrate)",
        min=0.0,
        max=5.0,
        unit="s",
    )
    search: str = param(
        _DEFAULTS.search,
        "what to do when nothing is tracked",
        choices=("sweep", "presets", "none"),
    )
    sweep_rate: float = param(
        _DEFAULTS.sweep_rate, "horizontal search sweep rate", min=0.0, max=5.0, unit="rad/s"
    )
    pan_limits: tuple[float, ...] = param(
        list(_DEFAULTS.pan_limits),
        "[min, max] pan: no command leaves it, the sweep reverses at it",
        unit="rad",
        interval=True,
    )
    tilt_limits: tuple[float, ...] = param(
        list(_DEFAULTS.tilt_limits), "[min, max] tilt commanded", unit="rad", interval=True
    )
    presets: tuple[float, ...] = param(
        [0.0, 0.0], "search presets as [pan1, tilt1, pan2, tilt2, ...]", unit="rad"
    )
    preset_dwell_time: float = param(
        _DEFAULTS.preset_dwell_time, "time at each preset", min=0.1, max=600.0, unit="s"
    )
    home: tuple[float, ...] = param(list(_DEFAULTS.home), "[pan, tilt] home preset", unit="rad")
    lost_scan_time: float = param(
        _DEFAULTS.lost_scan_time, "scan the last region this long", min=0.0, max=600.0, unit="s"
    )
    scan_amplitude: float = param(
        _DEFAULTS.scan_amplitude, "half-width of the scan", min=0.0, max=3.0, unit="rad"
    )
    scan_period: float = param(
        _DEFAULTS.scan_period, "period of the scan", min=0.1, max=60.0, unit="s"
    )
    home_dwell_time: float = param(
        _DEFAULTS.home_dwell_time,
        "time at home before searching",
        min=0.0,
        max=3600.0,
        unit="s",
    )
    zoom_control: bool = param(
        _DEFAULTS.zoom_control,
        "zoom so the target's height stays within [fill_low, fill_high] of the view's",
    )
    fill_low: float = param(
        _DEFAULTS.fill_low, "target / view height to zoom in below", min=0.0, max=1.0
    )
    fill_high: float = param(
        _DEFAULTS.fill_high, "target / view height to zoom out above", min=0.0, max=10.0
    )
    fill_target: float = param(
        _DEFAULTS.fill_target, "target / view height zoomed to", min=0.0, max=10.0
    )
    zoom_step: float = param(
        _DEFAULTS.zoom_step, "largest zoom ratio per command", min=1.001, max=10.0
    )
    home_zoom: float = param(_DEFAULTS.home_zoom, "zoom without a target", min=0.05, max=100.0)
    max_zoom: float = param(
        _DEFAULTS.max_zoom, "largest zoom the controller commands", min=0.05, max=100.0
    )

    def problems(self) -> list[str]:
        """Lists of the wrong length, then what the ControllerConfig they describe rejects."""
        found = [
            f"{name} needs exactly two values"
            for name in ("pan_limits", "tilt_limits", "home")
            if len(getattr(self, name)) != 2
        ]
        if len(self.presets) % 2:
            found.append(f"presets needs an even number of values, got {len(self.presets)}")
        return found or self.controller_config().problems()

    def controller_config(self) -> ControllerConfig:
        """The controller configuration these parameters describe (not checked: `problems`)."""
        flat = self.presets
        return ControllerConfig(
            mode=self.mode,
            kp=self.kp,
            ki=self.ki,
            dead_zone=self.dead_zone,
            max_rate=self.max_rate,
            feed_forward=self.feed_forward,
            aim_at_prediction=self.aim_at_prediction,
            unit_latency=self.unit_latency,
            search=self.search,
            sweep_rate=self.sweep_rate,
            pan_limits=(float(self.pan_limits[0]), float(self.pan_limits[1])),
            tilt_limits=(float(self.tilt_limits[0]), float(self.tilt_limits[1])),
            presets=tuple((float(flat[i]), float(flat[i + 1])) for i in range(0, len(flat) - 1, 2)),
            preset_dwell_time=self.preset_dwell_time,
            home=(float(self.home[0]), float(self.home[1])),
            lost_scan_time=self.lost_scan_time,
            scan_amplitude=self.scan_amplitude,
            scan_period=self.scan_period,
            home_dwell_time=self.home_dwell_time,
            zoom_control=self.zoom_control,
            fill_low=self.fill_low,
            fill_high=self.fill_high,
            fill_target=self.fill_target,
            zoom_step=self.zoom_step,
            home_zoom=self.home_zoom,
            max_zoom=self.max_zoom,
        )


def controller_config(values: Mapping[str, Any]) -> ControllerConfig:
    """The controller configuration the ptz_controller parameters describe (`ControllerParams`;
    raises ValueError when invalid)."""
    return config_from_params(ControllerParams, values).controller_config()


class PanTiltController:
    """One step per tracker cycle: `step(t, pose, target) -> Command`."""

    STALL_EPSILON = 1e-6  # rad: a sweep that moved less than this in a cycle has stopped

    def __init__(self, config: ControllerConfig) -> None:
        self._start(config)

    def _start(self, config: ControllerConfig) -> None:
        check_config(config)
        self.config = config
        self.state = ControlState.SEARCH if config.search != "none" else ControlState.HOME
        self._entered_at: float | None = None
        self._last_time: float | None = None
        self._integral = (0.0, 0.0)
        self._last_target_angles: tuple[float, float] | None = None
        self._sweep_direction = 1.0
        self._sweep_moved = False
        self._last_pan: float | None = None
        self._zooming = False
        self._resumed_at: float | None = None  # s: images or targets came back after a gap

    def reset(self) -> None:
        self._start(self.config)

    def step(self, t: float, pose: CameraPose, target: TargetEstimate | None) -> Command:
        """The command for time t [s] given the camera pose and the locked target (None if none)."""
        if target is not None:
            self._resumed_at = None  # taken up again (or never lost)
        elif self._reacquiring(t):
            return self.hold(t)
        dt = 0.0 if self._last_time is None else max(0.0, t - self._last_time)
        self._last_time = t
        if self.config.mode == "hold":  # a fixed camera: it stays where it is, whatever is tracked
            return Command(CommandMode.HOLD)
        self._update_state(t, target)
        if self.state is ControlState.TRACK and target is not None:  # TRACK needs a target
            command = self._track(pose, target, dt)
        elif self.state is ControlState.SCAN:
            command = self._scan(t, pose)
        elif self.state is ControlState.HOME:
            command = Command(
                CommandMode.POSITION, pan=self.config.home[0], tilt=self.config.home[1]
            )
        else:
            command = self._search(t, pose)
        self._last_pan = pose.pan
        if self.config.zoom_control:
            command = replace(command, zoom=self._zoom(pose, target))
        return self._within_limits(command, pose)

    def resume(self, t: float) -> None:
        """Images or targets return at time t [s] after a gap (a stream outage, a restarted
        detector). If the camera was following a target, the scan around its last position is
        done standing still until a target is locked again, for up to `lost_scan_time`: the
        tracker (which clears its tracks after a gap) and a restarted detector (relearning its
        background) need a still camera."""
        self._resumed_at = t

    def _reacquiring(self, t: float) -> bool:
        resumed = self._resumed_at
        return (
            resumed is not None
            and 0.0 <= t - resumed <= self.config.lost_scan_time
            and self.state is ControlState.TRACK
        )

    def hold(self, t: float) -> Command:
        """HOLD at time t [s] without a decision (no target can come, or it cannot be judged yet):
        the state is kept, and the time since the last step counts for none of its timers."""
        if self._last_time is not None and t < self._last_time:
            return Command(CommandMode.HOLD)  # an older image's answer: its time has passed
        if self._last_time is not None and self._entered_at is not None:
            self._entered_at += t - self._last_time
        self._last_time = t
        return Command(CommandMode.HOLD)

    def _within_limits(self, command: Command, pose: CameraPose) -> Command:
        """Positions clamped into the unit's range; a rate that would drive an axis further past
        its limit stopped."""
        pan_range, tilt_range = self.config.pan_limits, self.config.tilt_limits
        if command.mode is CommandMode.POSITION:
            return replace(
                command, pan=_clip(command.pan, *pan_range), tilt=_clip(command.tilt, *tilt_range)
            )
        if command.mode is CommandMode.VELOCITY:
            return replace(
                command,
                pan_rate=_stop_at_limit(command.pan_rate, pose.pan, *pan_range),
                tilt_rate=_stop_at_limit(command.tilt_rate, pose.tilt, *tilt_range),
            )
        return command

    def _zoom(self, pose: CameraPose, target: TargetEstimate | None) -> float:
        """The zoom to command (0: keep): the target's height back into the fill band, or the
        home zoom without a target; at most `zoom_step` away from the current zoom."""
        cfg = self.config
        if not (math.isfinite(pose.zoom) and pose.zoom > 0.0):
            return 0.0
        if self.state is ControlState.TRACK and target is not None:
            if not (0.0 < target.height < math.inf and 0.0 < pose.view_height < math.inf):
                return 0.0  # no usable height (NaN, 0 or infinite): keep the zoom
            fill = target.height / pose.view_height
            if not self._zooming and cfg.fill_low <= fill <= cfg.fill_high:
                return 0.0
            # the view's height scales as 1 / zoom
            wanted = min(pose.zoom * cfg.fill_target / fill, max(cfg.max_zoom, pose.zoom))
        else:
            wanted = cfg.home_zoom
        step = min(max(wanted, pose.zoom / cfg.zoom_step), pose.zoom * cfg.zoom_step)
        self._zooming = step != wanted  # a zoom once started goes on to fill_target
        return 0.0 if math.isclose(wanted, pose.zoom, rel_tol=1e-3) else step

    def _enter(self, state: ControlState, t: float) -> None:
        if state is not self.state:
            self.state = state
            self._entered_at = t
            self._integral = (0.0, 0.0)
        elif self._entered_at is None:
            self._entered_at = t

    def _time_in_state(self, t: float) -> float:
        return 0.0 if self._entered_at is None else t - self._entered_at

    def _update_state(self, t: float, target: TargetEstimate | None) -> None:
        if target is not None:
            self._enter(ControlState.TRACK, t)
            return
        if self._entered_at is None:
            self._entered_at = t
        elapsed = self._time_in_state(t)
        if self.state is ControlState.TRACK:
            self._enter(ControlState.SCAN if self._last_target_angles else ControlState.HOME, t)
        elif self.state is ControlState.SCAN and elapsed >= self.config.lost_scan_time:
            self._enter(ControlState.HOME, t)
        elif (
            self.state is ControlState.HOME
            and self.config.search != "none"
            and elapsed >= self.config.home_dwell_time
        ):
            self._enter(ControlState.SEARCH, t)

    def _track(self, pose: CameraPose, target: TargetEstimate, dt: float) -> Command:
        cfg = self.config
        aim_x, aim_y = (
            (target.predicted_x, target.predicted_y)
            if cfg.aim_at_prediction
            else (target.x, target.y)
        )
        aim_x += target.vx * cfg.unit_latency
        aim_y += target.vy * cfg.unit_latency
        # Scene x grows to the right while pan grows to the left; scene y and tilt both grow down.
        error_pan = -(aim_x - pose.center_x) / pose.focal_length
        error_tilt = (aim_y - pose.center_y) / pose.focal_length
        self._last_target_angles = (pose.pan + error_pan, pose.tilt + error_tilt)
        if cfg.mode == "direct":
            pan, tilt = self._last_target_angles
            return Command(CommandMode.POSITION, pan=pan, tilt=tilt)
        feed_pan, feed_tilt = (
            (-target.vx / pose.focal_length, target.vy / pose.focal_length)
            if cfg.feed_forward
            else (0.0, 0.0)
        )
        pan_rate, integral_pan = self._pi(error_pan, self._integral[0], feed_pan, dt)
        tilt_rate, integral_tilt = self._pi(error_tilt, self._integral[1], feed_tilt, dt)
        self._integral = (integral_pan, integral_tilt)
        return Command(CommandMode.VELOCITY, pan_rate=pan_rate, tilt_rate=tilt_rate)

    def _pi(self, error: float, integral: float, feed: float, dt: float) -> tuple[float, float]:
        """Rate command and new integral for one axis; no integration inside the dead zone or
        while saturated (anti-windup)."""
        cfg = self.config
        if abs(error) <= cfg.dead_zone:
            return _clamp(feed, cfg.max_rate), integral
        effective = error - math.copysign(cfg.dead_zone, error)
        rate = cfg.kp * effective + cfg.ki * integral + feed
        if abs(rate) < cfg.max_rate:
            integral += effective * dt
        return _clamp(rate, cfg.max_rate), integral

    def _scan(self, t: float, pose: CameraPose) -> Command:
        cfg = self.config
        center_pan, center_tilt = self._last_target_angles or (pose.pan, pose.tilt)
        phase = 2.0 * math.pi * self._time_in_state(t) / cfg.scan_period
        pan = center_pan + cfg.scan_amplitude * math.sin(phase)
        return Command(CommandMode.POSITION, pan=pan, tilt=center_tilt)

    def _search(self, t: float, pose: CameraPose) -> Command:
        cfg = self.config
        if cfg.search == "presets":
            elapsed = self._time_in_state(t)
            index = int(elapsed // cfg.preset_dwell_time) % len(cfg.presets)
            pan, tilt = cfg.presets[index]
            return Command(CommandMode.POSITION, pan=pan, tilt=tilt)
        low, high = cfg.pan_limits
        moved = self._last_pan is not None and abs(pose.pan - self._last_pan) >= self.STALL_EPSILON
        # A sweep that has been moving and stops has reached the unit's (or the scene's) limit.
        stalled = self._sweep_moved and not moved
        self._sweep_moved = self._sweep_moved or moved
        moving_out = (self._sweep_direction > 0 and pose.pan >= high) or (
            self._sweep_direction < 0 and pose.pan <= low
        )
        if moving_out or stalled:
            self._sweep_direction = -self._sweep_direction
            self._sweep_moved = False
        return Command(CommandMode.VELOCITY, pan_rate=self._sweep_direction * cfg.sweep_rate)


def _clamp(value: float, limit: float) -> float:
    return max(-limit, min(limit, value))


def _clip(value: float, low: float, high: float) -> float:
    return max(low, min(high, value))


def _stop_at_limit(rate: float, angle: float, low: float, high: float) -> float:
    return 0.0 if (angle >= high and rate > 0.0) or (angle <= low and rate < 0.0) else rate
