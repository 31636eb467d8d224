"""ptz_controller: turns the tracker's target into pan-tilt commands (thin shell over controller.py).

Subscribes `target` (tracker_msgs/Target) and `ptz/state` (tracker_msgs/PtzState); publishes one
`ptz/command` (tracker_msgs/PtzCommand) per target message, stamped with the image it responds to
(the lockstep acknowledgement), and optionally the same command as a sensor_msgs/JointState on
`joint_command_topic` in the unit's joints and the form its driver takes (`unit_joints.py`:
velocities or positions, or the FLIR PTU driver's positions with speeds). When targets stop
arriving (a crashed detector or tracker) it sends HOLD, so the camera never acts on stale commands.
"""

from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass
from typing import Any

from geometry_msgs.msg import PointStamped
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Header

from tracker_msgs.msg import PtzCommand, PtzState, Target
from tracker_msgs_py.codec import (
    MAX_MESSAGE_VALUE,
    NS_PER_S,
    command_qos,
    msg_to_window,
    ns_to_stamp,
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
from tracker_ptz_sim.control.command_messages import command_msg
from tracker_ptz_sim.control.controller import (
    CameraPose,
    Command,
    CommandMode,
    ControllerParams,
    PanTiltController,
    TargetEstimate,
    controller_config,
)
from tracker_ptz_sim.control.pan_tilt_frames import PanTiltFrames
from tracker_ptz_sim.control.unit_joints import (
    CommandStyle,
    JointCommand,
    JointMappingConfig,
    UnitSettings,
    unit_command,
)

STATE_BUFFER = 16  # pan-tilt states kept to pair with targets by stamp


@dataclass(frozen=True)
class PtzControllerNodeConfig:
    """The ptz_controller node's parameters: the controller's (`ControllerParams`), then how it
    pairs targets with states and sends joint commands."""

    control: ControllerParams = params_of(ControllerParams)
    target_timeout: float = param(
        1.0, "no target for this long (scene time) -> HOLD", min=0.05, max=60.0, unit="s"
    )
    state_timeout: float = param(
        0.5,
        "answer a target whose image's ptz/state has not come within this with HOLD",
        min=0.01,
        max=60.0,
        unit="s, wall",
    )
    max_state_age: float = param(
        0.25,
        "when a target's own ptz/state is lost, use an earlier one at most this old",
        min=0.0,
        max=10.0,
        unit="s",
    )
    joint_command_topic: str = param("", "also publish commands as JointState here ('' = off)")
    joint_names: tuple[str, ...] = param(["pan_joint", "tilt_joint"], "pan and tilt joint names")
    zoom_joint: str = param(
        "",
        "joint commands: the zoom joint, commanded by position when the zoom changes ('' = none)",
    )
    joint_command_style: str = param(
        CommandStyle.VELOCITY_OR_POSITION.value,
        "what a JointState command holds: velocity_or_position (velocities for servo moves, "
        "positions for direct moves; NaN = not commanded) or positions_with_speeds (the FLIR PTU "
        "driver's cmd: always two positions and two speeds >= 0)",
        choices=tuple(style.value for style in CommandStyle),
    )
    joint_speed_limits: tuple[float, ...] = param(
        [0.0, 1.0],
        "positions_with_speeds: [min, max] speed the unit accepts (its driver logs them)",
        unit="rad/s",
        interval=True,
    )
    position_lead: float = param(
        0.5,
        "positions_with_speeds: a rate becomes a goal this far ahead of the image's pose",
        min=0.01,
        max=10.0,
        unit="s",
    )
    joint_mapping: JointMappingConfig = params_of(JointMappingConfig)
    base_frame_id: str = param("ptz_base", "frame_id of the commands")
    optical_frame_id: str = param(
        "ptz_camera_optical",
        "frame of target_ray (the camera images' frame in the unit's TF tree)",
    )

    def problems(self) -> list[str]:
        if len(self.joint_names) != 2:
            return ["joint_names needs exactly two names (pan, tilt)"]
        try:
            self.unit_settings()
        except ValueError as error:
            return [str(error)]
        return []

    def unit_settings(self) -> UnitSettings:
        """How JointState commands reach the unit."""
        low, high = self.joint_speed_limits
        limits = self.control
        return UnitSettings(
            names=(self.joint_names[0], self.joint_names[1]),
            style=CommandStyle(self.joint_command_style),
            mapping=self.joint_mapping.mapping(),
            zoom_joint=self.zoom_joint,
            speed_limits=(float(low), float(high)),
            lead=self.position_lead,
            pan_limits=(float(limits.pan_limits[0]), float(limits.pan_limits[1])),
            tilt_limits=(float(limits.tilt_limits[0]), float(limits.tilt_limits[1])),
        )


PARAMS = list(specs_of(PtzControllerNodeConfig))


def _check(values: dict[str, Any]) -> str | None:
    try:
        config_from_params(PtzControllerNodeConfig, values)
    except ValueError as error:
        return str(error)
    return None


class PtzControllerNode(SuiteNode):
    def __init__(self, **node_options: Any) -> None:
        """node_options go to rclpy's Node (parameter_overrides, context...)."""
        super().__init__("ptz_controller", **node_options)
        self.params = declare_parameters(self, PARAMS, on_change=self._on_change, check_all=_check)
        self.settings = config_from_params(PtzControllerNodeConfig, self.params)
        self.controller = PanTiltController(controller_config(self.params))
        self.unit = self.settings.unit_settings()
        self.frames = PanTiltFrames()  # the ray's direction depends on the axes, not the names
        # Usable pan-tilt states by stamp, and the stamps of the latest unusable ones (their
        # images' targets are answered with HOLD).
        self.states: dict[int, CameraPose] = {}
        self.unusable_states: deque[int] = deque(maxlen=STATE_BUFFER)
        # Targets whose image's PtzState has not arrived yet (the two travel on different paths),
        # with the wall time they came.
        self.waiting: dict[int, tuple[Target, float]] = {}
        self.target_order = StampOrder()
        self.state_order = StampOrder()
        # The target watchdog: the image of the first state past the target timeout (answered once
        # the next state confirms the timeout), and whether targets are known to have stopped.
        self.unanswered_overdue: Any = None
        self.targets_stopped = False
        self.last_target_ns: int | None = None
        self.images_resumed_ns: int | None = None  # the first state after a gap in the images
        self.last_mode = CommandMode.HOLD
        self.command_pub = self.create_publisher(PtzCommand, "ptz/command", command_qos())
        # where the followed target is, for TF users: a point 1 m along its ray from the camera
        self.ray_pub = self.create_publisher(PointStamped, "target_ray", result_qos())
        self.joint_pub = self._joint_publisher()
        self.create_subscription(Target, "target", self._on_target, 10)
        self.create_subscription(PtzState, "ptz/state", self._on_state, 10)
        self.create_subscription(Float64, "ptz/unit_latency", self._on_unit_latency, result_qos())
        self.create_steady_timer(0.05, self._answer_overdue)

    def destroy_node(self) -> None:
        # A unit turning at the last commanded rate stops now, not at its own watchdog. Stamped
        # like the last image answered (a command carries the stamp of the image it answers).
        first_call = not self.stopping.is_set()
        self.stop_workers()
        if first_call and self.joint_pub is not None and self.last_target_ns is not None:
            newest_pose = self.states[max(self.states)] if self.states else None
            stop = unit_command(Command(CommandMode.HOLD), newest_pose, self.unit)
            if stop.positions or stop.velocities:
                header = Header(
                    stamp=ns_to_stamp(self.last_target_ns), frame_id=self.settings.base_frame_id
                )
                self.joint_pub.publish(joint_state(stop, header))
        super().destroy_node()

    def _joint_publisher(self) -> Publisher | None:
        topic = self.settings.joint_command_topic
        return self.create_publisher(JointState, topic, command_qos()) if topic else None

    def _on_change(self, changed: dict[str, Any]) -> None:
        self.settings = config_from_params(PtzControllerNodeConfig, self.params)
        self.controller.config = controller_config(self.params)
        self.unit = self.settings.unit_settings()
        if "joint_command_topic" in changed:
            if self.joint_pub is not None:
                self.destroy_publisher(self.joint_pub)
            self.joint_pub = self._joint_publisher()

    def _on_unit_latency(self, msg: Float64) -> None:
        """The unit's measured command latency (its driver's movement calibration) becomes the
        `unit_latency` parameter, through the same validation as a user's `ros2 param set`."""
        result = self.set_parameters([Parameter("unit_latency", value=float(msg.data))])[0]
        if result.successful:
            self.get_logger().info(f"unit_latency {msg.data:.3f} s, as the unit measured it")
        else:
            self.problems.report(
                "unusable unit latency",
                f"ignored ptz/unit_latency {msg.data}: {result.reason}",
            )

    # --- pan-tilt states ------------------------------------------------------------------------

    def _on_state(self, state: PtzState) -> None:
        stamp = stamp_to_ns(state.header.stamp)
        pose = pose_of(state)
        if isinstance(pose, str):  # refused before its stamp counts
            self.problems.report(pose, f"unusable PtzState stamped {stamp} ns: {pose}")
            if stamp not in self.unusable_states:
                self.unusable_states.append(stamp)
            if stamp in self.waiting:  # its target need not wait: it is answered with HOLD
                self._respond(self.waiting.pop(stamp)[0])
            return
        order = self.state_order.check(stamp)
        if order in (Order.REPEAT, Order.INVALID):
            self.problems.report(
                f"{order.value} state stamp",
                f"ignored a PtzState stamped {stamp} ns ({order.value}): "
                + ("the first one counts" if order is Order.REPEAT else "before zero"),
            )
            return
        if order is Order.NEW_EPOCH:
            self._forget_states_after(stamp)
        self._note_image_gap(stamp)
        self.states[stamp] = pose
        if stamp in self.unusable_states:  # a usable state of the same image wins
            self.unusable_states.remove(stamp)
        while len(self.states) > STATE_BUFFER:
            del self.states[min(self.states)]
        for target_stamp in sorted(t for t in self.waiting if t <= stamp):
            # A state this new came: the target's own is here, or it will not come.
            self._respond(self.waiting.pop(target_stamp)[0])
        self._watch_targets(stamp, state.header.stamp)

    def _note_image_gap(self, stamp_ns: int) -> None:
        """States (images) that resume after more than `target_timeout` without any (a stream
        that dropped and returned): the target timeout counts from here, as the targets of those
        images are still on their way and no target could come while there were no images; the
        control looks for its target standing still (`PanTiltController.resume`)."""
        previous = max((s for s in self.states if s < stamp_ns), default=None)
        timeout_ns = self.settings.target_timeout * NS_PER_S
        if previous is not None and stamp_ns - previous > timeout_ns:
            self.images_resumed_ns = stamp_ns
            self.controller.resume(stamp_ns / NS_PER_S)

    def _watch_targets(self, stamp_ns: int, stamp: Any) -> None:
        """Targets stopped (detector or tracker down) when two states in a row are more than
        `target_timeout` past the last target (one alone may carry a bad stamp) and past the end
        of a gap in the images: stop the camera, and acknowledge those states' images with HOLD
        until targets return."""
        timeout_ns = self.settings.target_timeout * NS_PER_S
        if self.last_target_ns is None:
            return
        since = max(self.last_target_ns, self.images_resumed_ns or 0)
        if stamp_ns - since <= timeout_ns:
            self.unanswered_overdue = None
            return
        if not self.targets_stopped:
            if self.unanswered_overdue is None:
                self.unanswered_overdue = stamp  # confirmed (or not) by the next state
                return
            self.targets_stopped = True
            self.problems.report(
                "targets stopped",
                f"no target for {(stamp_ns - self.last_target_ns) / NS_PER_S:.3f} s of scene time "
                "(is the detector or tracker running?): holding the camera until targets return",
            )
            self._hold(self.unanswered_overdue)
            self.unanswered_overdue = None
        self._hold(stamp)

    def _hold(self, stamp: Any) -> None:
        """HOLD for an image whose target is not coming: the control keeps its state, and the
        time held counts for none of its timers (a detector that restarts finds the camera where
        it was, still tracking, not sweeping away)."""
        self._publish(self.controller.hold(stamp_to_ns(stamp) / NS_PER_S), stamp)

    def _forget_states_after(self, stamp_ns: int) -> None:
        """The state stream jumped back (a new replay epoch, or past a lone state stamped ahead):
        the newer states are not of this stream's time."""
        newer = [s for s in self.states if s > stamp_ns]
        for old in newer:
            del self.states[old]
        self.get_logger().info(
            f"ptz/state: {self.state_order.describe_jump()}; forgot the {len(newer)} state(s) "
            "stamped after it"
        )
        self.unanswered_overdue = None
        if self.last_target_ns is not None and self.last_target_ns > stamp_ns:
            self.last_target_ns = stamp_ns  # the target timeout counts from the new epoch
        if self.images_resumed_ns is not None and self.images_resumed_ns > stamp_ns:
            self.images_resumed_ns = None

    # --- targets --------------------------------------------------------------------------------

    def _on_target(self, target: Target) -> None:
        stamp = stamp_to_ns(target.header.stamp)
        problem = unusable_target(target)
        already_answered = self.target_order.classify(stamp) in (Order.REPEAT, Order.INVALID)
        if problem is not None and not already_answered:
            # refused before its stamp counts or the control sees it; its image is acknowledged
            self.problems.report(
                "unusable target", f"answered a target stamped {stamp} ns with HOLD: {problem}"
            )
            self._publish(Command(CommandMode.HOLD), target.header.stamp)
            return
        order = self.target_order.check(stamp)
        if order in (Order.REPEAT, Order.INVALID):
            self.problems.report(
                f"{order.value} target stamp",
                f"ignored a target stamped {stamp} ns ({order.value}): each image is answered once",
            )
            return
        if order is Order.NEW_EPOCH:
            self._start_epoch(stamp)
        self.last_target_ns = stamp
        if self.targets_stopped:  # targets are back: the tracker takes its target up again
            self.controller.resume(stamp / NS_PER_S)
        self.targets_stopped = False
        self.unanswered_overdue = None
        if self._pose_known(stamp):
            self._respond(target)
        else:
            self.waiting[stamp] = (target, time.monotonic())

    def _start_epoch(self, stamp_ns: int) -> None:
        """Target stamps jumped back (a restarted or looping source): start the control afresh."""
        self.get_logger().info(
            f"targets: {self.target_order.describe_jump()}; a new replay epoch: the controller "
            "starts afresh"
        )
        self.controller.reset()
        for old in [s for s in self.waiting if s > stamp_ns]:
            del self.waiting[old]

    def _answer_overdue(self) -> None:
        """Targets whose state did not come in time are answered with HOLD (and acknowledged)."""
        now = time.monotonic()
        for stamp, (target, since) in sorted(self.waiting.items()):
            if now - since >= self.settings.state_timeout:
                del self.waiting[stamp]
                self._respond(target)

    def _pose_known(self, stamp_ns: int) -> bool:
        """Whether the target of this image can be answered now (its pose came, usable or not,
        or a newer state says it will not come)."""
        return stamp_ns in self.unusable_states or self._paired_pose(stamp_ns) is not None

    def _paired_pose(self, stamp_ns: int) -> CameraPose | None:
        """The pose of the target's image: its own state, or (when that was lost, i.e. a newer
        one exists) the latest earlier one at most `max_state_age` older."""
        if stamp_ns in self.states:
            return self.states[stamp_ns]
        if not self.states or max(self.states) < stamp_ns:
            return None
        earlier = [s for s in self.states if s < stamp_ns]
        if not earlier:
            return None
        nearest = max(earlier)
        if stamp_ns - nearest > self.settings.max_state_age * NS_PER_S:
            return None
        return self.states[nearest]

    def _respond(self, target: Target) -> None:
        """Step the controller with the target and the camera pose of the same image, or HOLD
        (reported) when that pose is unknown or unusable."""
        stamp = stamp_to_ns(target.header.stamp)
        pose = None if stamp in self.unusable_states else self._paired_pose(stamp)
        if pose is None:
            self._report_missing_pose(stamp)
            self._publish(Command(CommandMode.HOLD), target.header.stamp)
            return
        estimate = estimate_of(target)
        command = self.controller.step(stamp / NS_PER_S, pose, estimate)
        self._publish(command, target.header.stamp, pose)
        if estimate is not None and self.ray_pub.get_subscription_count():
            self.ray_pub.publish(self._ray(estimate, pose, target.header.stamp))

    def _ray(self, estimate: TargetEstimate, pose: CameraPose, stamp: Any) -> PointStamped:
        """The target 1 m along its ray in the optical frame of its image."""
        right = (estimate.x - pose.center_x) / pose.focal_length  # scene px per rad
        down = (estimate.y - pose.center_y) / pose.focal_length
        point = PointStamped()
        point.header.stamp, point.header.frame_id = stamp, self.settings.optical_frame_id
        ray = self.frames.ray(pose.pan, pose.tilt, right, down)
        point.point.x, point.point.y, point.point.z = ray
        return point

    def _report_missing_pose(self, stamp_ns: int) -> None:
        if stamp_ns in self.unusable_states:
            pass  # its state came but was unusable: reported when it came
        elif not self.states:
            self.problems.report(
                "no ptz/state yet",
                "targets arrive but no ptz/state has: is the camera or pan-tilt driver publishing "
                "ptz/state? Answering with HOLD",
            )
        else:
            self.problems.report(
                "no ptz/state for a target",
                f"no usable ptz/state for the image stamped {stamp_ns} ns within "
                f"{self.settings.state_timeout} s; answered with HOLD",
            )

    def diagnostic_state(self) -> tuple[str, dict[str, str]]:
        """The control state (track / scan / home / search), or holding the camera still."""
        state = "holding" if self.last_mode is CommandMode.HOLD else self.controller.state.value
        return state, {"mode": self.settings.control.mode, "last command": self.last_mode.value}

    def diagnostic_health(self) -> tuple[Health, str]:
        if self.last_target_ns is not None and not self.states:
            return Health.ERROR, "targets arrive but no usable ptz/state has: the camera holds"
        if self.targets_stopped:
            return Health.WARN, f"no target for over {self.settings.target_timeout} s: holding"
        return Health.OK, ""

    def _publish(self, command: Command, stamp: Any, pose: CameraPose | None = None) -> None:
        """The command on ptz/command and, when set, joint_command_topic. `pose`: where the camera
        looked in the image it answers (a positions_with_speeds hold or rate needs it: without
        it, no JointState goes out, and the unit keeps its last goal)."""
        self.last_mode = command.mode
        msg = command_msg(command, Header(stamp=stamp, frame_id=self.settings.base_frame_id))
        self.command_pub.publish(msg)
        if self.joint_pub is not None:
            joints = unit_command(command, pose, self.unit)
            if joints.positions or joints.velocities:
                self.joint_pub.publish(joint_state(joints, msg.header))


def pose_of(state: PtzState) -> CameraPose | str:
    """The camera pose a PtzState describes, or the reason it cannot be used."""
    if not (usable_value(state.focal_length) and state.focal_length > 0.0):
        return "focal_length is not a positive number (unset by the driver?)"
    if not all(usable_value(v) for v in (state.pan, state.tilt)):
        return f"pan or tilt not finite or beyond +-{MAX_MESSAGE_VALUE:g}"
    try:
        window = msg_to_window(state.window)
    except ValueError:
        return f"window is not a finite rectangle of positive size within +-{MAX_MESSAGE_VALUE:g}"
    center_x, center_y = window.center
    zoom = state.zoom if math.isfinite(state.zoom) and state.zoom > 0.0 else 1.0
    pose = CameraPose(
        state.pan, state.tilt, center_x, center_y, state.focal_length, zoom, window.height
    )
    return pose


def _target_values(target: Target) -> dict[str, float]:
    track = target.track
    return {
        "x": track.x,
        "y": track.y,
        "vx": track.vx,
        "vy": track.vy,
        "predicted_x": target.predicted_x,
        "predicted_y": target.predicted_y,
        "lead_time": target.lead_time,
        "height": track.bbox.height,
    }


def unusable_target(target: Target) -> str | None:
    """Why a locked target cannot be followed (a value not finite, or beyond MAX_MESSAGE_VALUE), or
    None; an unlocked target's fields are not read."""
    if not target.locked:
        return None
    for name, value in _target_values(target).items():
        if not usable_value(value):
            return f"{name} is {value} (finite, within +-{MAX_MESSAGE_VALUE:g}, expected)"
    if target.track.bbox.height < 0.0:
        return f"height is {target.track.bbox.height} (not negative expected)"
    return None


def estimate_of(target: Target) -> TargetEstimate | None:
    """The controller's view of a usable target (`unusable_target` None); None when unlocked."""
    if not target.locked:
        return None
    track = target.track
    values = (track.x, track.y, track.vx, track.vy, target.predicted_x, target.predicted_y)
    return TargetEstimate(*values, height=float(track.bbox.height))


def joint_state(command: JointCommand, header: Header) -> JointState:
    return JointState(
        header=header,
        name=command.names,
        position=command.positions,
        velocity=command.velocities,
    )


def main(args: list[str] | None = None) -> int:
    return run_node(PtzControllerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
