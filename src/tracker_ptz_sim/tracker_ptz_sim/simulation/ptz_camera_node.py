"""ptz_camera: a simulated pan-tilt-zoom camera looking at the replayed scene (thin shell over
camera_model.py).

Subscribes `scene/image_raw` and `ptz/command` (tracker_msgs/PtzCommand: position, velocity or
hold); for every scene image publishes the camera view `camera/image_raw` + `camera/camera_info`
(the window's intrinsics), `ptz/state` (tracker_msgs/PtzState) and `ptz/joint_states`
(sensor_msgs/JointState, pan and tilt in radians, REP-103 signs), all stamped with the scene image.

With `interface: standard` it stands in for a real unit's drivers instead: it speaks only
sensor_msgs (no PtzState; commands as JointState on `ptz/joint_command`, positions or velocities,
NaN = not commanded, plus the `zoom_joint` when named), the contract in the README's "On a real
pan-tilt unit", and its images are a pinhole camera's (`tracker_detect.pinhole`), not a linear
window of the scene.
A command answering image n acts from image n + `command_delay_frames` on (1: the next image).
In lockstep mode the camera processes scene image n only once a command stamped >= image
n - `command_delay_frames` has arrived (or after `lockstep_timeout`), because commands and images
travel on different topics: this makes a lockstep replay deterministic. With a delay of D frames,
video_source may keep D frames in flight (`frames_in_flight`), so the nodes of the graph work on
different frames at once; images that arrive early wait here, in order.
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from sensor_msgs.msg import CameraInfo, Image, JointState

from tracker_msgs.msg import PtzCommand as PtzCommandMsg
from tracker_msgs.msg import PtzState
from tracker_msgs_py.codec import (
    MAX_MESSAGE_VALUE,
    NS_PER_S,
    UnsupportedEncodingError,
    array_to_image,
    camera_info,
    command_qos,
    image_qos,
    image_to_array,
    rect_to_msg,
    result_qos,
    stamp_to_ns,
    usable_value,
)
from tracker_msgs_py.node_main import Health, SuiteNode, run_node
from tracker_msgs_py.params import (
    config_from_params,
    declare_parameters,
    param,
    params_of,
    specs_of,
)
from tracker_msgs_py.stamps import Order, StampOrder
from tracker_ptz_sim.simulation.camera_model import (
    PtzCameraModel,
    PtzCommand,
    PtzConfig,
    PtzSnapshot,
    view_size,
)
from tracker_ptz_sim.simulation.command_latency import CommandLatency, diagnostics_values

MODES = {
    PtzCommandMsg.MODE_POSITION: "position",
    PtzCommandMsg.MODE_VELOCITY: "velocity",
    PtzCommandMsg.MODE_HOLD: "hold",
}


@dataclass(frozen=True)
class PtzCameraNodeConfig:
    """The simulated camera's parameters: its model's, then the node's."""

    model: PtzConfig = params_of(PtzConfig)
    camera_frame_id: str = param("ptz_camera_optical", "frame_id of the camera images")
    scene_frame_id: str = param("scene", "frame_id of ptz/state (its window is in scene px)")
    joint_names: tuple[str, ...] = param(
        ["pan_joint", "tilt_joint"],
        "names of the pan and tilt joints",
        validator=lambda v: None if len(v) == 2 else "joint_names needs two names (pan, tilt)",
    )
    interface: str = param(
        "suite",
        "suite: PtzCommand in, PtzState out; standard: only sensor_msgs, like a real unit's "
        "drivers (JointState commands on ptz/joint_command)",
        choices=("suite", "standard"),
        read_only=True,
    )
    zoom_joint: str = param("", "standard interface: the zoom joint's name ('' = no zoom joint)")
    joint_command_style: str = param(
        "velocity_or_position",
        "standard interface: what its JointState commands hold: velocity_or_position (velocities "
        "where finite, else positions) or positions_with_speeds (a FLIR PTU's: two positions "
        "reached at two speeds, by index)",
        choices=("velocity_or_position", "positions_with_speeds"),
        read_only=True,
    )
    lockstep: bool = param(
        False, "process image n+1 only after a command acknowledging image n", read_only=True
    )
    lockstep_timeout: float = param(
        2.0, "stop waiting for that command after this", min=0.01, max=3600.0, unit="s"
    )
    reliable_images: bool = param(
        False, "reliable instead of sensor-data image QoS", read_only=True
    )

    def problems(self) -> list[str]:
        return []


PARAMS = specs_of(PtzCameraNodeConfig)
MODEL_FIELDS = {f.name for f in fields(PtzConfig)}  # the parameters the camera model reads
LOCKSTEP_WARN_S = 5.0  # diagnostics say WARN this long after a lockstep wait timed out


def _check(values: dict[str, Any], scene_size: tuple[int, int] | None = None) -> str | None:
    try:
        config = config_from_params(PtzCameraNodeConfig, values)
        if scene_size is not None:
            view_size(config.model, *scene_size)
    except ValueError as error:
        return str(error)
    return None


class PtzCameraNode(SuiteNode):
    def __init__(self, **node_options: Any) -> None:
        """node_options go to rclpy's Node (parameter_overrides, context...)."""
        super().__init__("ptz_camera", **node_options)
        self.params = declare_parameters(
            self, PARAMS, on_change=self._on_change, check_all=self._check_parameters
        )
        self.settings = config_from_params(PtzCameraNodeConfig, self.params)
        self.model: PtzCameraModel | None = None
        self.scene_order = StampOrder()
        self.last_image_ns: int | None = None
        self.last_command_ns = -1
        self.repeated_images = 0  # lockstep re-sends, dropped by design
        self.commands_received = 0
        # Lockstep: scene images waiting for their command, oldest first, and since when the
        # oldest waits; the stamps of the images processed last (the gate reads the oldest).
        self.pending: deque[tuple[Image, np.ndarray]] = deque()  # with its decoded pixels
        self.pending_since = 0.0
        self.lockstep_timed_out_at: float | None = None  # time.monotonic() of the latest
        self.processed_ns: deque[int] = deque(maxlen=self.settings.model.command_delay_frames)
        self.early_commands: list[PtzCommand] = []
        self.last_snapshot: PtzSnapshot | None = None
        self.latency = CommandLatency()  # camera image out -> its command in
        qos = image_qos(self.settings.reliable_images)
        self.view_pub = self.create_publisher(Image, "camera/image_raw", qos)
        self.info_pub = self.create_publisher(CameraInfo, "camera/camera_info", qos)
        self.standard = self.settings.interface == "standard"
        self.state_pub = (
            None if self.standard else self.create_publisher(PtzState, "ptz/state", result_qos())
        )
        self.joint_pub = self.create_publisher(JointState, "ptz/joint_states", result_qos())
        self.create_subscription(Image, "scene/image_raw", self._on_scene, qos)
        if self.standard:
            self.create_subscription(
                JointState,
                "ptz/joint_command",
                self._on_joint_command,
                command_qos(),
            )
        else:
            self.create_subscription(PtzCommandMsg, "ptz/command", self._on_command, command_qos())
        if self.settings.lockstep:
            self.create_steady_timer(0.05, self._on_lockstep_timer)

    def _check_parameters(self, values: dict[str, Any]) -> str | None:
        model = getattr(self, "model", None)
        return _check(values, None if model is None else (model.width, model.height))

    def _on_change(self, changed: dict[str, Any]) -> None:
        self.settings = config_from_params(PtzCameraNodeConfig, self.params)
        if self.model is not None and MODEL_FIELDS & changed.keys():
            self.model.reconfigure(self.settings.model)

    # --- commands -------------------------------------------------------------------------------

    def diagnostic_health(self) -> tuple[Health, str]:
        timed_out = self.lockstep_timed_out_at
        if timed_out is not None and time.monotonic() - timed_out < LOCKSTEP_WARN_S:
            return (
                Health.WARN,
                "a lockstep wait for a command timed out: is the controller running?",
            )
        return Health.OK, ""

    def diagnostic_state(self) -> tuple[str, dict[str, str]]:
        if self.model is None:
            return "waiting for the first scene image", {}
        state = (
            f"{len(self.pending)} image(s) waiting for a command (lockstep)"
            if self.pending
            else "streaming"
        )
        details = {"interface": self.settings.interface}
        if self.last_snapshot is not None:
            shot = self.last_snapshot
            details |= {"pan [rad]": f"{shot.pan:.4f}", "tilt [rad]": f"{shot.tilt:.4f}"}
            details["zoom"] = f"{shot.zoom:.3f}"
        details |= diagnostics_values(self.latency)
        return state, details

    def _on_command(self, msg: PtzCommandMsg) -> None:
        self._apply(self._command_from(msg), stamp_to_ns(msg.header.stamp))

    def _on_joint_command(self, msg: JointState) -> None:
        self._apply(self._joint_command_from(msg), stamp_to_ns(msg.header.stamp))

    def _apply(self, command: PtzCommand | None, stamp: int) -> None:
        if stamp < 0:  # no image has one (they are dropped): it answers nothing
            self.problems.report(
                "negative stamp", f"ignored a pan-tilt command stamped {stamp / NS_PER_S:.3f} s"
            )
            return
        self.latency.command_received(stamp, time.monotonic_ns())
        self.commands_received += 1
        if command is not None and self.last_image_ns is not None and stamp > self.last_image_ns:
            self.problems.report(
                "command from the future",
                f"ignored a pan-tilt command stamped {stamp / NS_PER_S:.3f} s, after the latest scene "
                f"image ({self.last_image_ns / NS_PER_S:.3f} s): commands carry the stamp of the image "
                "they answer",
            )
            command = None
        if command is not None:
            if self.model is not None:
                self.model.command(command)
            else:
                self.early_commands.append(command)  # before the first image: applied at start
        # Even a rejected command acknowledges its image: the controller did answer it. One
        # stamped after the newest image answers another epoch's image and acknowledges nothing.
        if self.last_image_ns is None or stamp <= self.last_image_ns:
            self.last_command_ns = max(self.last_command_ns, stamp)
        self._process_pending()

    def _command_from(self, msg: PtzCommandMsg) -> PtzCommand | None:
        """The model's command, or None (reported) for a command the camera cannot act on."""
        stamp = stamp_to_ns(msg.header.stamp)
        mode = MODES.get(msg.mode)
        values = (msg.pan, msg.tilt, msg.pan_rate, msg.tilt_rate)
        if mode is None:
            self.problems.report(
                "unknown command mode",
                f"ignored a pan-tilt command with unknown mode {msg.mode} (known: "
                f"{', '.join(f'{k} = {v}' for k, v in MODES.items())})",
            )
        elif not all(usable_value(v) for v in values):
            self.problems.report(
                "unusable command values",
                f"ignored a pan-tilt command with values {values} (finite, within "
                f"+-{MAX_MESSAGE_VALUE:g}, expected)",
            )
        elif not _usable_zoom(msg.zoom):
            self.problems.report(
                "invalid zoom",
                f"ignored a pan-tilt command with zoom {msg.zoom} ({ZOOM_RULE})",
            )
        else:
            return PtzCommand(
                stamp / NS_PER_S, mode, msg.pan, msg.tilt, msg.pan_rate, msg.tilt_rate, msg.zoom
            )
        return None

    def _joint_command_from(self, msg: JointState) -> PtzCommand | None:
        """A JointState command: velocities where given (finite), else positions; or None."""
        if self.settings.joint_command_style == "positions_with_speeds":
            return self._position_with_speeds(msg)
        stamp = stamp_to_ns(msg.header.stamp)
        names = list(msg.name)
        pan_name, tilt_name = self.settings.joint_names
        if pan_name not in names or tilt_name not in names:
            self.problems.report(
                "joint command without the joints",
                f"ignored a JointState command without {pan_name} and {tilt_name} (names {names})",
            )
            return None
        zoom = math.nan
        zoom_joint = self.settings.zoom_joint
        if zoom_joint in names and len(msg.position) == len(names):
            zoom = float(msg.position[names.index(zoom_joint)])
        if not _usable_zoom(zoom):
            self.problems.report(
                "invalid zoom",
                f"ignored a JointState command with {zoom_joint} {zoom} ({ZOOM_RULE})",
            )
            return None
        given = (
            _joint_pair(msg.velocity, names, pan_name, tilt_name),
            _joint_pair(msg.position, names, pan_name, tilt_name),
        )
        rates, angles = _finite_pair(given[0]), _finite_pair(given[1])
        corrupt = [v for pair in given for v in pair if not (math.isnan(v) or usable_value(v))]
        if corrupt:  # NaN means "not commanded"; a value beyond any motion is a corrupt message
            self.problems.report(
                "joint command beyond range",
                f"ignored a JointState command with {corrupt[0]} (within +-{MAX_MESSAGE_VALUE:g} "
                "expected)",
            )
            return None
        if rates is not None:
            return PtzCommand(stamp / NS_PER_S, "velocity", 0.0, 0.0, *rates, zoom)
        if angles is not None:
            return PtzCommand(stamp / NS_PER_S, "position", *angles, 0.0, 0.0, zoom)
        self.problems.report(
            "joint command without values",
            "ignored a JointState command with neither finite velocities nor positions for the "
            "pan and tilt joints",
        )
        return None

    def _position_with_speeds(self, msg: JointState) -> PtzCommand | None:
        """As the FLIR PTU driver reads its `cmd`: exactly two positions [pan, tilt] by index, and
        two speeds (else speed 0: the unit stays); None (reported) otherwise."""
        values = [*msg.position, *msg.velocity]
        if len(msg.position) != 2 or not all(usable_value(float(v)) for v in values):
            self.problems.report(
                "not two positions",
                f"ignored a JointState command with positions {list(msg.position)}: the "
                "positions_with_speeds style needs exactly two finite positions (pan, tilt)",
            )
            return None
        speeds = (abs(msg.velocity[0]), abs(msg.velocity[1])) if len(msg.velocity) == 2 else (0, 0)
        stamp = stamp_to_ns(msg.header.stamp) / NS_PER_S
        pan, tilt = float(msg.position[0]), float(msg.position[1])
        return PtzCommand(stamp, "position", pan, tilt, speeds=(float(speeds[0]), float(speeds[1])))

    # --- images ---------------------------------------------------------------------------------

    def _on_scene(self, msg: Image) -> None:
        stamp = stamp_to_ns(msg.header.stamp)
        try:  # before its stamp counts: a dropped image must not move the camera's clock
            scene = image_to_array(msg)
        except UnsupportedEncodingError as error:
            self.problems.report(error.cause, f"dropped a scene image: {error}")
            return
        order = self.scene_order.check(stamp)
        if order is Order.REPEAT:
            self.repeated_images += 1
            return
        if order is Order.INVALID:
            self.problems.report("negative stamp", f"dropped a scene image stamped {stamp} ns")
            return
        if order is Order.NEW_EPOCH:
            self._start_epoch(stamp)
        elif len(self.pending) >= self.settings.model.command_delay_frames:
            # More images in flight than commands may lag (or no lockstep): the oldest goes on.
            self._process(*self.pending.popleft())
            self.pending_since = time.monotonic()
        if not self.pending:
            self.pending_since = time.monotonic()
        self.pending.append((msg, scene))
        self._process_pending()

    def _start_epoch(self, stamp_ns: int) -> None:
        """Time jumped back (a restarted or looping source): a new time base for the camera and
        the lockstep gate; the camera keeps its pose."""
        self.get_logger().info(
            f"scene {self.scene_order.describe_jump()}: a new replay epoch; the camera keeps its "
            "pose and drops the commands of the old one"
        )
        self.pending.clear()
        self.processed_ns.clear()
        self.latency.forget_pending()
        self.last_image_ns = None
        self.last_command_ns = -1
        self.early_commands.clear()
        if self.model is not None:
            self.model.restart_clock(stamp_ns / NS_PER_S)

    def _acknowledged(self) -> bool:
        """Lockstep: has the command the next image waits for come (the answer to the image
        `command_delay_frames` before it)?"""
        gate = self.processed_ns
        return (
            not self.settings.lockstep
            or len(gate) < (gate.maxlen or 1)
            or self.last_command_ns >= gate[0]
        )

    def _process_pending(self) -> None:
        while self.pending and self._acknowledged():
            self._process(*self.pending.popleft())
            self.pending_since = time.monotonic()

    def _on_lockstep_timer(self) -> None:
        if not self.pending:
            return
        if time.monotonic() - self.pending_since >= self.settings.lockstep_timeout:
            self.get_logger().warning(
                "no pan-tilt command acknowledged the image the next one waits for within "
                f"{self.params['lockstep_timeout']} s; going on without it",
                throttle_duration_sec=5.0,
            )
            self.lockstep_timed_out_at = time.monotonic()
            self._process(*self.pending.popleft())
            self.pending_since = time.monotonic()
            self._process_pending()

    def _process(self, msg: Image, scene: np.ndarray) -> None:
        stamp = stamp_to_ns(msg.header.stamp)
        size_changed = self.model is None or (self.model.width, self.model.height) != (
            msg.width,
            msg.height,
        )
        if size_changed and not self._start_model(msg.width, msg.height):
            return
        self.last_image_ns = stamp
        self.processed_ns.append(stamp)
        model = self.model
        assert model is not None, "_start_model made it"
        snapshot = model.advance(stamp / NS_PER_S)
        # A stand-in for a real unit's drivers takes the images a real (pinhole) camera would.
        view = model.render(scene, snapshot.window, pinhole=self.standard)
        self._publish(msg, view, snapshot)

    def _start_model(self, width: int, height: int) -> bool:
        """A camera for a scene of this size (False, reported, when it cannot have one)."""
        try:
            model = PtzCameraModel(self.settings.model, width, height)
        except ValueError as error:
            self.problems.report("scene too small", f"dropped a scene image: {error}")
            return False
        if self.model is not None:
            self.get_logger().warning(f"scene size changed to {width}x{height}: camera restarted")
        self.model = model
        for command in self.early_commands:
            self.model.command(command)
        self.early_commands.clear()
        base_w, base_h = self.model.base_size
        self.get_logger().info(
            f"scene {width}x{height}: view {base_w}x{base_h} px, focal length "
            f"{self.model.geometry.focal_length:.1f} px/rad, pan range +-{self.model.limits()[0][1]:.3f} rad"
        )
        return True

    def _publish(self, scene_msg: Image, view: Any, snapshot: PtzSnapshot) -> None:
        self.last_snapshot = snapshot
        stamp = scene_msg.header.stamp
        camera_frame = self.settings.camera_frame_id
        model = self.model
        assert model is not None, "published only after the model exists"
        fx, fy, cx, cy = model.intrinsics()
        height, width = view.shape[:2]
        self.latency.image_sent(stamp_to_ns(stamp), time.monotonic_ns())
        self.view_pub.publish(array_to_image(view, scene_msg.encoding, stamp, camera_frame))
        self.info_pub.publish(camera_info(width, height, fx, fy, cx, cy, stamp, camera_frame))
        state = PtzState(
            pan=snapshot.pan,
            tilt=snapshot.tilt,
            pan_rate=snapshot.pan_rate,
            tilt_rate=snapshot.tilt_rate,
            zoom=snapshot.zoom,
            focal_length=model.geometry.focal_length,
            window=rect_to_msg(snapshot.window),
            moving=snapshot.moving,
        )
        state.header.stamp = stamp
        state.header.frame_id = self.settings.scene_frame_id
        if self.state_pub is not None:
            self.state_pub.publish(state)
        joints = JointState(
            name=list(self.settings.joint_names),
            position=[snapshot.pan, snapshot.tilt],
            velocity=[snapshot.pan_rate, snapshot.tilt_rate],
        )
        if self.standard and self.settings.zoom_joint:
            joints.name.append(self.settings.zoom_joint)
            joints.position.append(snapshot.zoom)
            joints.velocity.append(0.0)
        joints.header.stamp = stamp
        joints.header.frame_id = "ptz_base"
        self.joint_pub.publish(joints)


ZOOM_RULE = f"a positive number up to {MAX_MESSAGE_VALUE:g}, or 0 or NaN to keep the zoom"


def _usable_zoom(zoom: float) -> bool:
    """A commanded zoom the camera can act on (ZOOM_RULE)."""
    return math.isnan(zoom) or (usable_value(zoom) and zoom >= 0)


def _joint_pair(values: Any, names: list[str], pan_name: str, tilt_name: str) -> tuple[float, ...]:
    """The (pan, tilt) values of a JointState array (its velocities or positions), by joint
    name; () when the array does not give one value per name."""
    if len(values) != len(names):
        return ()
    return (float(values[names.index(pan_name)]), float(values[names.index(tilt_name)]))


def _finite_pair(pair: tuple[float, ...]) -> tuple[float, float] | None:
    """`pair` as a (pan, tilt) command when it has both and both are finite, else None."""
    return (pair[0], pair[1]) if pair and all(map(math.isfinite, pair)) else None


def main(args: list[str] | None = None) -> int:
    return run_node(PtzCameraNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
