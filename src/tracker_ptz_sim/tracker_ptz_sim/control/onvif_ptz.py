"""An ONVIF PTZ camera, driven through onvif-zeep-async (the client Frigate uses; no rclpy).

ONVIF moves a head in normalized *generic spaces*: position x (pan), y (tilt) in [-1, 1], and
velocities in [-1, 1] of the camera's top speed. `GenericRange` maps them to the suite's REP-103
angles: the pan and tilt the camera looks at when x (y) is -1 and when it is +1 (most cameras
count x + = right and y + = up, the other way from REP-103: a range from + to -), and the rates
[rad/s] at velocity 1.

`OnvifPtz` reads at start what the camera's profile supports (`PtzSupport`: continuous,
absolute and relative moves, FOV-relative moves, presets, a position in GetStatus) and then moves
it: ContinuousMove with a timeout (the camera's own watchdog), AbsoluteMove, RelativeMove, Stop,
GotoPreset, GetStatus. A camera whose MoveStatus never returns to IDLE (a common fault) is judged
still by its position (`StillJudge`). `fit_response` fits a timed move's positions to a latency
and a rate, as Frigate's movement calibration does.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

FOV_TRANSLATION = "http://www.onvif.org/ver10/tptz/PanTiltSpaces/TranslationSpaceFov"


class OnvifError(RuntimeError):
    """A camera that cannot be used, with the cause in one line."""


@dataclass(frozen=True)
class GenericRange:
    """REP-103 pan and tilt [rad] at generic -1 and +1, and rates [rad/s] at velocity 1."""

    pan: tuple[float, float] = (math.pi, -math.pi)  # x + = right
    tilt: tuple[float, float] = (math.pi / 2, -math.pi / 2)  # y + = up
    top_rates: tuple[float, float] = (1.0, 1.0)

    def __post_init__(self) -> None:
        if self.pan[0] == self.pan[1] or self.tilt[0] == self.tilt[1]:
            raise ValueError("pan_range and tilt_range need two different ends")
        if not all(rate > 0.0 for rate in self.top_rates):
            raise ValueError(f"top_rates must be positive, got {list(self.top_rates)}")

    @staticmethod
    def _to_angle(value: float, ends: tuple[float, float]) -> float:
        return ends[0] + (value + 1.0) / 2.0 * (ends[1] - ends[0])

    @staticmethod
    def _to_generic(angle: float, ends: tuple[float, float]) -> float:
        return min(max(2.0 * (angle - ends[0]) / (ends[1] - ends[0]) - 1.0, -1.0), 1.0)

    def angles(self, x: float, y: float) -> tuple[float, float]:
        return self._to_angle(x, self.pan), self._to_angle(y, self.tilt)

    def generic(self, pan: float, tilt: float) -> tuple[float, float]:
        """The generic position of REP-103 angles (clipped to [-1, 1])."""
        return self._to_generic(pan, self.pan), self._to_generic(tilt, self.tilt)

    def velocity(self, pan_rate: float, tilt_rate: float) -> tuple[float, float]:
        """Generic velocities of REP-103 rates (clipped to [-1, 1]): the sign of each range."""
        out = []
        for rate, ends, top in zip(
            (pan_rate, tilt_rate), (self.pan, self.tilt), self.top_rates, strict=True
        ):
            direction = 1.0 if ends[1] > ends[0] else -1.0
            out.append(min(max(direction * rate / top, -1.0), 1.0))
        return out[0], out[1]


@dataclass(frozen=True)
class PtzSupport:
    """What the camera's PTZ profile offers."""

    profile: str
    continuous: bool
    absolute: bool
    relative: bool
    relative_fov: bool
    presets: tuple[str, ...]
    position_in_status: bool

    def describe(self) -> str:
        """One line: what the camera does and does not support."""
        names = {
            "ContinuousMove": self.continuous,
            "AbsoluteMove": self.absolute,
            "RelativeMove": self.relative,
            "FOV-relative moves": self.relative_fov,
            "a position in GetStatus": self.position_in_status,
        }
        has = [name for name, ok in names.items() if ok]
        lacks = [name for name, ok in names.items() if not ok]
        presets = f"{len(self.presets)} preset(s)" + (
            f" ({', '.join(self.presets)})" if self.presets else ""
        )
        line = f"profile {self.profile}: {', '.join(has) or 'no moves'}, {presets}"
        return line + (f"; not supported: {', '.join(lacks)}" if lacks else "")


@dataclass(frozen=True)
class PtzStatus:
    """One GetStatus: the generic position (None when the camera gives none), its MoveStatus
    ('IDLE', 'MOVING', 'UNKNOWN' or None) and when it was taken (monotonic, the request's
    midpoint)."""

    x: float | None
    y: float | None
    move_status: str | None
    taken_at: float


class StillJudge:
    """Is the head moving? MoveStatus says so, unless it has not reported IDLE since the start
    while the position has changed by less than `tolerance` over the last `polls` polls: a
    camera whose MoveStatus never returns to IDLE is judged by its position."""

    def __init__(self, polls: int = 3, tolerance: float = 1e-3) -> None:
        self.polls, self.tolerance = polls, tolerance
        self.recent: list[tuple[float, float]] = []
        self.seen_idle = False

    def moving(self, status: PtzStatus) -> bool:
        if status.x is not None and status.y is not None:
            self.recent = [*self.recent, (status.x, status.y)][-self.polls :]
        if status.move_status == "IDLE":
            self.seen_idle = True
            return False
        if self.seen_idle and status.move_status == "MOVING":
            return True
        # never IDLE so far, or no MoveStatus at all: the position tells
        if len(self.recent) < self.polls:
            return True
        spread = np.ptp(np.asarray(self.recent), axis=0)
        return bool(spread.max() > self.tolerance)


def fit_response(
    times: Sequence[float], positions: Sequence[float], commanded_at: float
) -> tuple[float, float]:
    """A timed move's response: the latency [s] from `commanded_at` until the position starts to
    change, and the rate [units/s] it then keeps (a line through the moving part)."""
    t = np.asarray(times, dtype=float) - commanded_at
    p = np.asarray(positions, dtype=float)
    if len(t) < 4:
        raise ValueError("a response needs at least four positions")
    moved = np.abs(p - p[0]) > 1e-6
    if not moved.any() or moved.sum() < 2:
        raise ValueError("the position did not change: the camera did not move")
    rate, offset = np.polyfit(t[moved], p[moved], 1)
    latency = (p[0] - offset) / rate if rate else 0.0
    return max(0.0, float(latency)), float(rate)


def _first(value: Any) -> Any:
    if isinstance(value, list | tuple):
        return value[0] if value else None
    return value


@dataclass(frozen=True)
class Calibration:
    """A timed pan move's response: `latency` [s] from the command until the head moves, and
    `rate` [generic units/s] per unit of ContinuousMove velocity."""

    latency: float
    rate: float


async def calibrate(ptz: OnvifPtz, velocity: float = 0.5, seconds: float = 1.0) -> Calibration:
    """Frigate's movement calibration in short: pan at `velocity` for `seconds`, polling the
    position as fast as the camera answers, fit its response (`fit_response`), stop and go back
    to where it started (AbsoluteMove where the camera has it, else the same move reversed)."""
    start = await ptz.status()
    commanded_at = time.monotonic()
    await ptz.continuous_move(velocity, 0.0, timeout=seconds + 1.0)
    times, positions = [], []
    while time.monotonic() - commanded_at < seconds:
        status = await ptz.status()
        if status.x is not None:
            times.append(status.taken_at)
            positions.append(status.x)
    await ptz.stop()
    support = ptz.support
    if support is not None and support.absolute and start.x is not None and start.y is not None:
        await ptz.absolute_move(start.x, start.y)
    else:
        await ptz.continuous_move(-velocity, 0.0, timeout=seconds)
    latency, rate = fit_response(times, positions, commanded_at)
    return Calibration(latency, rate / velocity)


class OnvifPtz:
    """One camera's PTZ service (async; every method waits for the camera's answer)."""

    def __init__(self, host: str, port: int, user: str, password: str, timeout: float = 5.0):
        self.host, self.port, self.user, self.password = host, port, user, password
        self.timeout = timeout
        self.camera: Any = None
        self.ptz: Any = None
        self.support: PtzSupport | None = None

    async def connect(self, profile: str = "") -> PtzSupport:
        """Connect, pick the profile (`profile`, or the first with a PTZ configuration) and read
        what it supports; OnvifError with the cause in one line otherwise."""
        from onvif import ONVIFCamera

        self.camera = ONVIFCamera(self.host, self.port, self.user, self.password)
        try:
            await self.camera.update_xaddrs()
            media = await self.camera.create_media_service()
            self.ptz = await self.camera.create_ptz_service()
            profiles = await media.GetProfiles()
            chosen = [
                p
                for p in profiles or []
                if getattr(p, "PTZConfiguration", None) is not None
                and (not profile or p.token == profile)
            ]
            if not chosen:
                tokens = [p.token for p in profiles or []]
                wanted = f"profile '{profile}'" if profile else "a profile with PTZ"
                raise OnvifError(f"the camera has no {wanted} (profiles: {tokens})")
            self.support = await self._support(chosen[0])
        except OnvifError:
            await self.close()
            raise
        except Exception as error:  # the client raises many types; the cause goes in one line
            await self.close()
            raise OnvifError(self._cause(error)) from error
        return self.support

    def _cause(self, error: Exception) -> str:
        text = str(error) or type(error).__name__
        where = f"{self.host}:{self.port}"
        lowered = text.lower()
        if "not authorized" in lowered or "notauthorized" in lowered or "401" in text:
            return f"{where} refused the user name or password"
        if "connect call failed" in lowered or "cannot connect" in lowered or "refused" in lowered:
            return f"{where} refused the connection (no ONVIF service there?)"
        return f"{where}: {text}"

    async def _support(self, profile: Any) -> PtzSupport:
        config = profile.PTZConfiguration
        options = await self.ptz.GetConfigurationOptions({"ConfigurationToken": config.token})
        spaces = options.Spaces
        translation = getattr(spaces, "RelativePanTiltTranslationSpace", None) or []
        presets = await self.ptz.GetPresets({"ProfileToken": profile.token}) or []
        status = await self.ptz.GetStatus({"ProfileToken": profile.token})
        position = getattr(status, "Position", None)
        return PtzSupport(
            profile=profile.token,
            continuous=bool(getattr(spaces, "ContinuousPanTiltVelocitySpace", None)),
            absolute=bool(getattr(spaces, "AbsolutePanTiltPositionSpace", None)),
            relative=bool(translation),
            relative_fov=any(space.URI == FOV_TRANSLATION for space in translation),
            presets=tuple(str(p.token) for p in presets),
            position_in_status=getattr(position, "PanTilt", None) is not None,
        )

    @property
    def _profile(self) -> str:
        assert self.support is not None, "connect first"
        return self.support.profile

    async def continuous_move(self, vx: float, vy: float, timeout: float) -> None:
        await self.ptz.ContinuousMove(
            {
                "ProfileToken": self._profile,
                "Velocity": {"PanTilt": {"x": vx, "y": vy}},
                "Timeout": f"PT{timeout:.3f}S",
            }
        )

    async def absolute_move(self, x: float, y: float, speed: float = 1.0) -> None:
        await self.ptz.AbsoluteMove(
            {
                "ProfileToken": self._profile,
                "Position": {"PanTilt": {"x": x, "y": y}},
                "Speed": {"PanTilt": {"x": speed, "y": speed}},
            }
        )

    async def relative_move(self, dx: float, dy: float, fov: bool = False) -> None:
        translation: dict[str, Any] = {"x": dx, "y": dy}
        if fov:
            translation["space"] = FOV_TRANSLATION
        await self.ptz.RelativeMove(
            {"ProfileToken": self._profile, "Translation": {"PanTilt": translation}}
        )

    async def stop(self) -> None:
        await self.ptz.Stop({"ProfileToken": self._profile, "PanTilt": True, "Zoom": False})

    async def goto_preset(self, token: str) -> None:
        await self.ptz.GotoPreset({"ProfileToken": self._profile, "PresetToken": token})

    async def status(self) -> PtzStatus:
        sent = time.monotonic()
        status = await self.ptz.GetStatus({"ProfileToken": self._profile})
        taken_at = (sent + time.monotonic()) / 2.0
        pan_tilt = getattr(getattr(status, "Position", None), "PanTilt", None)
        move = getattr(status, "MoveStatus", None)
        move_status = _first(getattr(move, "PanTilt", None)) if move is not None else None
        if pan_tilt is None:
            return PtzStatus(None, None, move_status, taken_at)
        return PtzStatus(float(pan_tilt.x), float(pan_tilt.y), move_status, taken_at)

    async def close(self) -> None:
        if self.camera is not None:
            camera, self.camera = self.camera, None
            await camera.close()
