"""ptz_state_bridge: a real pan-tilt unit's standard messages as the suite's PtzState (thin shell
over joint_pose.py).

Subscribes `ptz/joint_states` (sensor_msgs/JointState: pan, tilt [rad, REP-103], optionally a zoom
joint) and `camera/camera_info` (sensor_msgs/CameraInfo, one per image, the image's stamp);
publishes one `ptz/state` (tracker_msgs/PtzState) per CameraInfo, stamped like it, with the pose
interpolated at that stamp, or the latest joint state carried forward by the rates the controller
commanded since (`ptz/command`), for units that report their joints seldom. With it the
detector, tracker and controller run behind any driver that publishes what FLIR PTU or Axis
drivers do, unchanged.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

from sensor_msgs.msg import CameraInfo, JointState

from tracker_detect.image_pose_pairing import SceneSettings
from tracker_detect.registration import CameraIntrinsics
from tracker_msgs.msg import PtzCommand, PtzState
from tracker_msgs_py.codec import (
    MAX_MESSAGE_VALUE,
    NS_PER_S,
    command_qos,
    image_qos,
    joint_values,
    ns_to_stamp,
    rect_to_msg,
    result_qos,
    stamp_to_ns,
    usable_value,
)
from tracker_msgs_py.node_main import SuiteNode, run_node
from tracker_msgs_py.params import (
    config_from_params,
    declare_parameters,
    param,
    params_of,
    specs_of,
)
from tracker_ptz_sim.control.command_messages import command_of
from tracker_ptz_sim.control.controller import CommandMode
from tracker_ptz_sim.control.joint_pose import JointPoseBridge, JointSample, PtzPose
from tracker_ptz_sim.control.unit_joints import CommandedMotion, JointMappingConfig


@dataclass(frozen=True)
class PtzStateBridgeConfig:
    """The ptz_state_bridge node's parameters."""

    joint_names: tuple[str, ...] = param(
        ["pan_joint", "tilt_joint"],
        "pan and tilt joints of JointState",
        validator=lambda v: None if len(v) == 2 else "joint_names needs two names (pan, tilt)",
        read_only=True,
    )
    zoom_joint: str = param(
        "", "JointState joint whose position is the zoom ('' = none)", read_only=True
    )
    scene_width: int = param(
        0, "scene width (0 = the camera image's)", min=0, max=1_000_000, unit="px"
    )
    scene_height: int = param(
        0, "scene height (0 = the camera image's)", min=0, max=1_000_000, unit="px"
    )
    scene_focal_length: float = param(
        0.0,
        "scene px per radian (0 = the first CameraInfo's fx at zoom 1)",
        min=0.0,
        max=1e9,
        read_only=True,
    )
    joint_buffer_size: int = param(64, "joint states kept", min=2, max=10000, read_only=True)
    max_gap: float = param(
        0.5,
        "interpolate between joint states at most this far apart",
        min=0.0,
        max=60.0,
        unit="s",
    )
    pose_wait: float = param(
        0.2,
        "an image waits this long for a joint state after its stamp, then takes the latest one "
        "before it",
        min=0.0,
        max=10.0,
        unit="s, wall",
    )
    max_pose_age: float = param(
        0.5, "that earlier joint state may be at most this old", min=0.0, max=60.0, unit="s"
    )
    scene_frame_id: str = param("scene", "frame_id of ptz/state (its window is in scene px)")
    reliable_images: bool = param(
        False, "reliable QoS for camera_info (lockstep replays)", read_only=True
    )
    command_topic: str = param(
        "ptz/command",
        "the controller's commands (tracker_msgs/PtzCommand): their rates carry the latest joint "
        "state forward to an image's stamp ('' = take the latest joint state as it is)",
        read_only=True,
    )
    joint_mapping: JointMappingConfig = params_of(JointMappingConfig)

    def problems(self) -> list[str]:
        return []


PARAMS = list(specs_of(PtzStateBridgeConfig))


class PtzStateBridgeNode(SuiteNode):
    def __init__(self, **node_options: Any) -> None:
        """node_options go to rclpy's Node (parameter_overrides, context...)."""
        super().__init__("ptz_state_bridge", **node_options)
        self.params = declare_parameters(self, PARAMS, on_change=self._on_change)
        self.settings = config_from_params(PtzStateBridgeConfig, self.params)
        settings = self.settings
        self.bridge = JointPoseBridge(
            self._scene(),
            settings.joint_buffer_size,
            round(settings.max_gap * NS_PER_S),
            round(settings.max_pose_age * NS_PER_S),
            CommandedMotion() if settings.command_topic else None,
        )
        self.mapping = settings.joint_mapping.mapping()
        self.arrivals: dict[int, float] = {}  # waiting image stamps -> wall time they came
        self.state_pub = self.create_publisher(PtzState, "ptz/state", result_qos())
        qos = image_qos(settings.reliable_images, depth=settings.joint_buffer_size)
        self.create_subscription(JointState, "ptz/joint_states", self._on_joints, qos)
        self.create_subscription(CameraInfo, "camera/camera_info", self._on_camera_info, qos)
        if settings.command_topic:
            self.create_subscription(
                PtzCommand, settings.command_topic, self._on_command, command_qos()
            )
        self.create_steady_timer(0.02, self._release_overdue)
        self.get_logger().info("ptz_state_bridge ready")

    def _scene(self) -> SceneSettings:
        settings = self.settings
        return SceneSettings(
            settings.scene_width, settings.scene_height, settings.scene_focal_length
        )

    def diagnostic_state(self) -> tuple[str, dict[str, str]]:
        if self.bridge.joints.newest_stamp is None:
            return "waiting for ptz/joint_states", {}
        waiting = len(self.bridge.waiting)
        state = f"{waiting} image(s) waiting for a joint state" if waiting else "bridging"
        return state, {"scene focal length [px/rad]": f"{self.bridge.focal_length or 0.0:.1f}"}

    def _on_change(self, changed: dict[str, Any]) -> None:
        self.settings = config_from_params(PtzStateBridgeConfig, self.params)
        self.bridge.scene = self._scene()
        self.bridge.joints.max_gap_ns = round(self.settings.max_gap * NS_PER_S)
        self.bridge.max_age_ns = round(self.settings.max_pose_age * NS_PER_S)

    def _on_joints(self, msg: JointState) -> None:
        sample = self._sample(msg)
        if sample is not None:
            self._publish(self.bridge.add_joints(sample))

    def _sample(self, msg: JointState) -> JointSample | None:
        names = list(msg.name)
        wanted = list(self.settings.joint_names)
        zoom_joint = self.settings.zoom_joint
        needed = wanted + [zoom_joint] if zoom_joint else wanted
        positions = joint_values(names, msg.position, needed)
        if positions is None:
            self.problems.report(
                "JointState without the joints",
                f"ignored a JointState without positions for {needed} (names {names})",
            )
            return None
        pan, tilt = self.mapping.from_joints(*positions[:2])
        zoom = positions[2] if zoom_joint else math.nan
        usable_zoom = not zoom_joint or (usable_value(zoom) and zoom > 0.0)
        if not (usable_value(pan) and usable_value(tilt) and usable_zoom):
            self.problems.report(
                "unusable joint position",
                f"ignored a JointState with pan/tilt/zoom {pan, tilt, zoom} (finite, within "
                f"+-{MAX_MESSAGE_VALUE:g}, zoom positive, expected)",
            )
            return None
        pan_rate = tilt_rate = math.nan  # the bridge differentiates positions instead
        if len(msg.velocity) == len(names):
            pan_rate, tilt_rate = joint_values(names, msg.velocity, wanted) or (math.nan, math.nan)
        if not all(math.isnan(v) or usable_value(v) for v in (pan_rate, tilt_rate)):
            self.problems.report(
                "unusable joint velocity",
                f"ignored a JointState with pan/tilt rates {pan_rate, tilt_rate} (NaN for unknown, "
                f"or within +-{MAX_MESSAGE_VALUE:g}, expected)",
            )
            return None
        pan_rate, tilt_rate = self.mapping.rates_to_joints(pan_rate, tilt_rate)  # its own inverse
        return JointSample(stamp_to_ns(msg.header.stamp), pan, tilt, zoom, pan_rate, tilt_rate)

    def _on_command(self, msg: PtzCommand) -> None:
        command = command_of(msg)
        if command is None:
            rates = (msg.pan_rate, msg.tilt_rate)
            self.problems.report(
                "unusable command", f"ignored a PtzCommand with mode {msg.mode}, rates {rates}"
            )
            return
        velocity = command.mode is CommandMode.VELOCITY
        rates = (command.pan_rate, command.tilt_rate) if velocity else (0.0, 0.0)
        motion = self.bridge.motion
        if motion is not None:
            motion.add(stamp_to_ns(msg.header.stamp), *rates)

    def _on_camera_info(self, msg: CameraInfo) -> None:
        try:
            camera = CameraIntrinsics.of_camera_info(msg)
        except ValueError as error:
            self.problems.report("invalid CameraInfo", f"ignored a CameraInfo: {error}")
            return
        stamp = stamp_to_ns(msg.header.stamp)
        self.arrivals[stamp] = time.monotonic()
        self._publish(self.bridge.add_camera_info(stamp, camera))

    def _release_overdue(self) -> None:
        waiting = self.bridge.waiting
        if (
            waiting
            and time.monotonic() - self.arrivals.get(waiting[0][0], 0.0) >= self.settings.pose_wait
        ):
            self._publish(self.bridge.give_up())

    def _publish(self, poses: list[PtzPose]) -> None:
        for stamp, why in self.bridge.dropped:
            self.arrivals.pop(stamp, None)
            self.problems.report(why, f"no ptz/state for the image stamped {stamp} ns: {why}")
        self.bridge.dropped.clear()
        for pose in poses:
            self.arrivals.pop(pose.stamp_ns, None)
            self.state_pub.publish(self._state(pose))

    def _state(self, pose: PtzPose) -> PtzState:
        state = PtzState(
            pan=pose.pan,
            tilt=pose.tilt,
            pan_rate=pose.pan_rate,
            tilt_rate=pose.tilt_rate,
            zoom=pose.zoom,
            focal_length=pose.focal_length,
            window=rect_to_msg(pose.window),
            moving=pose.moving,
        )
        state.header.stamp = ns_to_stamp(pose.stamp_ns)
        state.header.frame_id = self.settings.scene_frame_id
        return state


def main(args: list[str] | None = None) -> int:
    return run_node(PtzStateBridgeNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
