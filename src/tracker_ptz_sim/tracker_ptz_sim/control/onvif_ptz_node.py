"""onvif_ptz: an ONVIF PTZ camera as the graph's pan-tilt unit (thin shell over onvif_ptz.py).

Subscribes `ptz/command` (tracker_msgs/PtzCommand) and `target` (tracker_msgs/Target: whether a
target is locked); publishes `ptz/joint_states` (sensor_msgs/JointState: `joint_names` pan and
tilt [rad, REP-103] from GetStatus at `status_rate`, stamped at each request's midpoint), which
`ptz_state_bridge` pairs with the camera's images. Rates become ContinuousMove (with
`move_timeout` as the camera's own watchdog, renewed while a rate holds), holds a Stop, direct
moves and search presets an AbsoluteMove (a RelativeMove, or a rate toward the goal, on cameras
without one). With `return_preset`, after `return_after` s without a locked target the camera
goes to that preset and waits there, deaf to commands, until a target is locked again. It stops
when the node shuts down. What the camera supports is one line at start; a camera that cannot
report its position cannot be followed (start-up error).
"""

from __future__ import annotations

import asyncio
import contextlib
import math
import threading
import time
from collections.abc import Coroutine
from dataclasses import dataclass
from typing import Any, TypeVar

from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from tracker_msgs.msg import PtzCommand, Target
from tracker_msgs_py.codec import command_qos, result_qos
from tracker_msgs_py.node_main import Health, StartupError, SuiteNode, run_node
from tracker_msgs_py.params import config_from_params, declare_parameters, param, specs_of
from tracker_ptz_sim.control.command_messages import command_of
from tracker_ptz_sim.control.controller import CameraPose, Command, CommandMode
from tracker_ptz_sim.control.onvif_ptz import (
    Calibration,
    GenericRange,
    OnvifError,
    OnvifPtz,
    PtzStatus,
    StillJudge,
    calibrate,
)
from tracker_ptz_sim.control.unit_joints import JointMapping, velocity_only

T = TypeVar("T")


def _two(name: str) -> Any:
    return lambda v: None if len(v) == 2 else f"{name} needs two values"


def _pair(values: tuple[float, ...]) -> tuple[float, float]:
    """A two-value parameter (`_two` checked its length) as a pair."""
    return float(values[0]), float(values[1])


@dataclass(frozen=True)
class OnvifPtzConfig:
    """The onvif_ptz node's parameters."""

    host: str = param("", "the camera's address (name or IP)", read_only=True)
    port: int = param(80, "the camera's ONVIF (HTTP) port", min=1, max=65535, read_only=True)
    user: str = param("", "ONVIF user name ('' = none)", read_only=True)
    password: str = param("", "ONVIF password (never logged)", read_only=True)
    profile: str = param("", "media profile token ('' = the first with PTZ)", read_only=True)
    pan_range: tuple[float, ...] = param(
        [math.pi, -math.pi],
        "REP-103 pan the camera looks at for generic x = -1 and x = +1 (x + = right on most "
        "cameras: a range from + to -)",
        unit="rad",
        validator=_two("pan_range"),
        read_only=True,
    )
    tilt_range: tuple[float, ...] = param(
        [math.pi / 2, -math.pi / 2],
        "REP-103 tilt (+ = down) at generic y = -1 and y = +1",
        unit="rad",
        validator=_two("tilt_range"),
        read_only=True,
    )
    top_rates: tuple[float, ...] = param(
        [1.0, 1.0],
        "[pan, tilt] rate of ContinuousMove velocity 1",
        unit="rad/s",
        validator=_two("top_rates"),
        read_only=True,
    )
    status_rate: float = param(5.0, "GetStatus polls per second", min=0.2, max=50.0, read_only=True)
    move_timeout: float = param(
        1.0,
        "ContinuousMove timeout: the camera stops by itself when commands stop coming",
        min=0.1,
        max=60.0,
        unit="s",
    )
    position_gain: float = param(
        2.0,
        "cameras without position moves: rate per rad to go",
        min=0.01,
        max=100.0,
        unit="1/s",
    )
    return_preset: str = param(
        "", "preset to go to after return_after s without a target ('' = none)"
    )
    return_after: float = param(
        10.0,
        "time without a locked target before the return preset",
        min=0.0,
        max=3600.0,
        unit="s",
    )
    still_polls: int = param(
        3,
        "polls over which an unchanged position means still (for cameras whose MoveStatus "
        "never returns to IDLE)",
        min=2,
        max=100,
    )
    joint_names: tuple[str, ...] = param(
        ["pan_joint", "tilt_joint"],
        "pan and tilt joints of joint_states",
        validator=_two("joint_names"),
    )
    connect_timeout: float = param(
        10.0,
        "time to wait for the camera at start",
        min=0.5,
        max=600.0,
        unit="s",
        read_only=True,
    )
    calibrate: bool = param(
        False,
        "at start, time a 1 s pan at half speed and fit its latency and rate: the measured pan "
        "rate replaces top_rates[0] (the camera moves and comes back)",
        read_only=True,
    )

    def problems(self) -> list[str]:
        return []


PARAMS = list(specs_of(OnvifPtzConfig))


class OnvifPtzNode(SuiteNode):
    def __init__(self, **node_options: Any) -> None:
        """node_options go to rclpy's Node (parameter_overrides, context...)."""
        super().__init__("onvif_ptz", **node_options)
        self.params = declare_parameters(self, PARAMS, on_change=self._on_change)
        self.settings = config_from_params(OnvifPtzConfig, self.params)
        p = self.settings
        if not p.host:
            raise StartupError("host is empty: give the camera's address (host:=192.168.1.20)")
        try:
            self.range = GenericRange(_pair(p.pan_range), _pair(p.tilt_range), _pair(p.top_rates))
        except ValueError as error:
            raise StartupError(str(error)) from error
        self.loop = asyncio.new_event_loop()
        self.loop_thread = threading.Thread(
            target=self.loop.run_forever, name="onvif_ptz.loop", daemon=True
        )
        self.loop_thread.start()
        self.camera = OnvifPtz(p.host, p.port, p.user, p.password)
        try:
            self.support = self._wait(self.camera.connect(p.profile), p.connect_timeout)
        except (OnvifError, TimeoutError) as error:
            self._stop_loop()
            cause = str(error) or f"no answer within {p.connect_timeout} s"
            raise StartupError(f"ONVIF camera {p.host}:{p.port}: {cause}") from error
        self.get_logger().info(f"ONVIF camera {p.host}:{p.port}, {self.support.describe()}")
        if not self.support.position_in_status:
            self._stop_loop()
            raise StartupError(
                "the camera's GetStatus reports no position: the graph needs where the camera "
                "looked for each image, so this camera cannot be followed with"
            )
        self.calibration: Calibration | None = None
        if p.calibrate and self.support.continuous:
            self._calibrate()
        self.judge = StillJudge(p.still_polls)
        self.pose: tuple[float, float] | None = None  # REP-103 pan, tilt of the newest status
        self.moving = False
        self.sent: tuple[str, tuple[float, ...]] | None = (
            None  # the last move sent, to skip repeats
        )
        self.sent_at = 0.0
        self.last_locked = time.monotonic()
        self.at_return_preset = False
        self.errors = 0
        self.joint_pub = self.create_publisher(JointState, "ptz/joint_states", result_qos())
        if self.calibration is not None:  # for the controller, also one that starts later
            latency_pub = self.create_publisher(Float64, "ptz/unit_latency", result_qos())
            latency_pub.publish(Float64(data=float(self.calibration.latency)))
        self.create_subscription(PtzCommand, "ptz/command", self._on_command, command_qos())
        self.create_subscription(Target, "target", self._on_target, 10)
        self.poller = asyncio.run_coroutine_threadsafe(self._poll(), self.loop)
        self.create_steady_timer(0.2, self._check_return)

    def _on_change(self, changed: dict[str, Any]) -> None:
        self.settings = config_from_params(OnvifPtzConfig, self.params)

    def _calibrate(self) -> None:
        """Measure the pan response; the measured rate replaces top_rates[0]."""
        try:
            measured = self._wait(calibrate(self.camera), 10.0)
        except Exception as error:  # no motion seen, a refused move, no answer: rates as given
            self.get_logger().warning(f"calibration failed ({error}): top_rates kept as given")
            return
        self.calibration = measured
        span = abs(self.range.pan[1] - self.range.pan[0]) / 2.0  # rad per generic unit
        pan_rate = abs(measured.rate) * span
        self.get_logger().info(
            f"calibration: the head moves {measured.latency:.3f} s after a command, at "
            f"{pan_rate:.3f} rad/s for velocity 1 (top_rates[0] was {self.range.top_rates[0]}); "
            "the latency goes to the controller (ptz/unit_latency)"
        )
        self.range = GenericRange(
            self.range.pan, self.range.tilt, (pan_rate, self.range.top_rates[1])
        )

    # --- the event loop -----------------------------------------------------------------------

    def _wait(self, coroutine: Coroutine[Any, Any, T], timeout: float) -> T:
        return asyncio.run_coroutine_threadsafe(coroutine, self.loop).result(timeout)

    def _send(self, coroutine: Coroutine[Any, Any, None], what: str) -> None:
        """Send a move without waiting; a failure is reported, never raised."""
        future = asyncio.run_coroutine_threadsafe(coroutine, self.loop)
        future.add_done_callback(lambda f: self._report(f, what))

    def _report(self, future: Any, what: str) -> None:
        error = future.exception()
        if error is not None and not self.stopping.is_set():
            self.errors += 1
            self.problems.report(f"{what} failed", f"the camera refused {what}: {error}")

    def _stop_loop(self) -> None:
        if self.loop.is_running():
            with contextlib.suppress(Exception):  # closing a camera that never answered
                self._wait(self.camera.close(), 2.0)
            self.loop.call_soon_threadsafe(self.loop.stop)
        self.loop_thread.join(5.0)

    async def _poll(self) -> None:
        period = 1.0 / self.settings.status_rate
        while not self.stopping.is_set():
            started = time.monotonic()
            try:
                self._publish(await self.camera.status())
            except Exception as error:  # a camera that stops answering: reported, polled on
                if not self.stopping.is_set():
                    self.errors += 1
                    self.problems.report("GetStatus failed", f"GetStatus failed: {error}")
            await asyncio.sleep(max(0.0, period - (time.monotonic() - started)))

    def _publish(self, status: PtzStatus) -> None:
        if status.x is None or status.y is None or self.stopping.is_set():
            return
        self.moving = self.judge.moving(status)
        pan, tilt = self.range.angles(status.x, status.y)
        self.pose = (pan, tilt)
        age_ns = round((time.monotonic() - status.taken_at) * 1e9)
        stamp = self.get_clock().now().nanoseconds - age_ns
        msg = JointState(name=list(self.settings.joint_names), position=[pan, tilt])
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
        self.joint_pub.publish(msg)

    # --- commands -----------------------------------------------------------------------------

    def _on_target(self, msg: Target) -> None:
        if msg.locked:
            self.last_locked = time.monotonic()
            self.at_return_preset = False

    def _check_return(self) -> None:
        settings = self.settings
        preset = settings.return_preset
        if not preset or self.at_return_preset:
            return
        if time.monotonic() - self.last_locked >= settings.return_after:
            self.at_return_preset = True
            self.sent = None
            self.get_logger().info(f"no target for {settings.return_after} s: to preset {preset}")
            self._send(self.camera.goto_preset(preset), f"GotoPreset {preset}")

    def _on_command(self, msg: PtzCommand) -> None:
        command = command_of(msg)
        if command is None:
            values = (msg.pan, msg.tilt, msg.pan_rate, msg.tilt_rate)
            self.problems.report(
                "unusable command", f"stopped for a PtzCommand with mode {msg.mode}, {values}"
            )
            command = Command(CommandMode.HOLD)
        if self.at_return_preset:
            return  # waiting at the return preset for a target
        self._act(command)

    def _act(self, command: Command) -> None:
        support = self.support
        if command.mode is CommandMode.POSITION and (support.absolute or support.relative):
            goal = self.range.generic(command.pan, command.tilt)
            if support.absolute:
                self._move("absolute", goal, self.camera.absolute_move(*goal))
            elif self.pose is not None:
                here = self.range.generic(*self.pose)
                step = (goal[0] - here[0], goal[1] - here[1])
                self._move("absolute", goal, self.camera.relative_move(*step))
            return
        if command.mode is CommandMode.POSITION:  # no position moves: a rate toward the goal
            pose = None if self.pose is None else CameraPose(*self.pose, 0.0, 0.0, 1.0)
            rates = velocity_only(
                command,
                pose,
                JointMapping(),
                self.settings.position_gain,
                max(self.range.top_rates),
            )
        elif command.mode is CommandMode.VELOCITY:
            rates = (command.pan_rate, command.tilt_rate)
        else:
            rates = (0.0, 0.0)
        velocity = self.range.velocity(*rates)
        if velocity == (0.0, 0.0):
            self._move("stop", (), self.camera.stop())
        else:
            timeout = self.settings.move_timeout
            self._move("continuous", velocity, self.camera.continuous_move(*velocity, timeout))

    def _move(self, kind: str, values: tuple[float, ...], coroutine: Any) -> None:
        """Send the move unless it repeats the last one (a continuous move is renewed after half
        its timeout, so the camera's watchdog does not stop it while the rate holds)."""
        now = time.monotonic()
        renew = kind == "continuous" and now - self.sent_at > self.settings.move_timeout / 2
        if (kind, values) == self.sent and not renew:
            coroutine.close()
            return
        self.sent, self.sent_at = (kind, values), now
        self._send(coroutine, {"stop": "Stop", "continuous": "ContinuousMove"}.get(kind, "a move"))

    # --- diagnostics and shutdown -------------------------------------------------------------

    def diagnostic_state(self) -> tuple[str, dict[str, str]]:
        state = (
            "at the return preset"
            if self.at_return_preset
            else ("moving" if self.moving else "still")
        )
        details = {
            "camera": f"{self.settings.host}:{self.settings.port}",
            "supports": self.support.describe(),
            "errors": str(self.errors),
        }
        if self.calibration is not None:
            details["calibrated latency [s]"] = f"{self.calibration.latency:.3f}"
            details["pan top rate [rad/s]"] = f"{self.range.top_rates[0]:.3f}"
        return state, details

    def diagnostic_health(self) -> tuple[Health, str]:
        if self.pose is None:
            return Health.WARN, "no position from the camera yet"
        return Health.OK, ""

    def destroy_node(self) -> None:
        if not self.stopping.is_set():
            self.stopping.set()
            try:
                self._wait(self.camera.stop(), 2.0)  # the camera stops now, not at its timeout
            except Exception as error:
                self.get_logger().warning(f"could not stop the camera at shutdown: {error}")
            self.poller.cancel()
            self._stop_loop()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run_node(OnvifPtzNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
