"""ptz_tf: the pan-tilt unit's TF tree from its joint states, where robot_state_publisher is not
installed (the PyPI wheels); with it, robot_state_publisher on `robot_description` does the same.

Publishes `robot_description` (std_msgs/String, the URDF of `pan_tilt_frames`, transient local),
`/tf_static` once (the fixed links: camera link and optical frame) and, for each
`ptz/joint_states` (sensor_msgs/JointState), `/tf` with the pan and tilt joints' transforms stamped
like it, so rviz, Foxglove's 3D panel or a robot's TF listener can tell where the camera looks
(`<prefix>ptz_camera_optical`, the images' frame, in `<prefix>ptz_base`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from geometry_msgs.msg import TransformStamped
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from tracker_msgs_py.codec import joint_values, result_qos, usable_value
from tracker_msgs_py.node_main import SuiteNode, run_node
from tracker_msgs_py.params import config_from_params, declare_parameters, param, specs_of
from tracker_ptz_sim.control.pan_tilt_frames import PanTiltFrames, Transform

LATCHED = QoSProfile(
    depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
)  # what tf2's static broadcaster and robot_state_publisher offer
TF_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)  # tf2's broadcaster


@dataclass(frozen=True)
class PtzTfConfig:
    """The ptz_tf node's parameters."""

    frame_prefix: str = param("", "prefix of every frame and joint name ('cam1/')", read_only=True)
    joint_names: tuple[str, ...] = param(
        ["pan_joint", "tilt_joint"], "pan and tilt names in the joint states"
    )

    def problems(self) -> list[str]:
        return []


PARAMS = list(specs_of(PtzTfConfig))


class PtzTfNode(SuiteNode):
    def __init__(self, **node_options: Any) -> None:
        """node_options go to rclpy's Node (namespace, parameter_overrides, context...)."""
        super().__init__("ptz_tf", **node_options)
        self.params = declare_parameters(self, PARAMS, on_change=self._on_change)
        self.settings = config_from_params(PtzTfConfig, self.params)
        self.frames = PanTiltFrames(self.settings.frame_prefix)
        self.tf_pub = self.create_publisher(TFMessage, "/tf", TF_QOS)
        static_pub = self.create_publisher(TFMessage, "/tf_static", LATCHED)
        static_pub.publish(TFMessage(transforms=[to_msg(t, None) for t in self.frames.fixed()]))
        description_pub = self.create_publisher(String, "robot_description", LATCHED)
        description_pub.publish(String(data=self.frames.urdf()))
        self.create_subscription(JointState, "ptz/joint_states", self._on_joints, result_qos())
        self.get_logger().info(f"ptz_tf ready: {self.frames.base} -> {self.frames.optical}")

    def _on_change(self, changed: dict[str, Any]) -> None:
        self.settings = config_from_params(PtzTfConfig, self.params)

    def _on_joints(self, msg: JointState) -> None:
        wanted = list(self.settings.joint_names)
        angles = joint_values(list(msg.name), msg.position, wanted)
        if angles is None or not all(usable_value(a) for a in angles):
            self.problems.report(
                "unusable joint state",
                f"ignored a JointState without usable positions for {wanted} (names "
                f"{list(msg.name)}, positions {list(msg.position)})",
            )
            return
        pan, tilt = angles
        transforms = [to_msg(t, msg.header.stamp) for t in self.frames.moving(pan, tilt)]
        self.tf_pub.publish(TFMessage(transforms=transforms))


def to_msg(transform: Transform, stamp: Any) -> TransformStamped:
    msg = TransformStamped()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.header.frame_id, msg.child_frame_id = transform.parent, transform.child
    t, r = msg.transform.translation, msg.transform.rotation
    t.x, t.y, t.z = transform.translation
    r.x, r.y, r.z, r.w = transform.rotation
    if not math.isclose(r.x * r.x + r.y * r.y + r.z * r.z + r.w * r.w, 1.0, rel_tol=1e-9):
        raise ValueError(f"{transform.child}: rotation is not a unit quaternion")
    return msg


def main(args: list[str] | None = None) -> int:
    return run_node(PtzTfNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
