"""axis_ptz_adapter: the suite's commands as the Axis camera driver takes them (thin shell over
unit_joints.velocity_only).

Subscribes `ptz/command` (tracker_msgs/PtzCommand) and `ptz/state` (where the camera looked, for
direct moves); publishes `cmd/velocity` (ptz_action_server_msgs/Ptz: pan and tilt rates [rad/s]
in the camera's joints, zoom speed 0), what the axis_camera driver (ROS 2) turns into a VAPIX
continuous move. The camera keeps moving until it is told otherwise, so every hold is a zero and
the adapter sends one when it shuts down.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ptz_action_server_msgs.msg import Ptz

from tracker_msgs.msg import PtzCommand, PtzState
from tracker_msgs_py.codec import command_qos, usable_value
from tracker_msgs_py.node_main import SuiteNode, run_node
from tracker_msgs_py.params import (
    config_from_params,
    declare_parameters,
    param,
    params_of,
    specs_of,
)
from tracker_ptz_sim.control.command_messages import command_of
from tracker_ptz_sim.control.controller import CameraPose, Command, CommandMode
from tracker_ptz_sim.control.unit_joints import JointMappingConfig, velocity_only


@dataclass(frozen=True)
class AxisPtzAdapterConfig:
    """The axis_ptz_adapter node's parameters."""

    position_gain: float = param(
        2.0,
        "a direct move or search preset: pan/tilt rate per radian still to go",
        min=0.01,
        max=100.0,
        unit="1/s",
    )
    max_rate: float = param(1.0, "largest rate sent", min=0.01, max=10.0, unit="rad/s")
    joint_mapping: JointMappingConfig = params_of(JointMappingConfig)

    def problems(self) -> list[str]:
        return []


PARAMS = list(specs_of(AxisPtzAdapterConfig))


class AxisPtzAdapterNode(SuiteNode):
    def __init__(self, **node_options: Any) -> None:
        """node_options go to rclpy's Node (parameter_overrides, context...)."""
        super().__init__("axis_ptz_adapter", **node_options)
        self.params = declare_parameters(self, PARAMS, on_change=self._on_change)
        self.settings = config_from_params(AxisPtzAdapterConfig, self.params)
        self.mapping = self.settings.joint_mapping.mapping()
        self.pose: CameraPose | None = None
        self.sent = False
        self.velocity_pub = self.create_publisher(Ptz, "cmd/velocity", command_qos())
        self.create_subscription(PtzCommand, "ptz/command", self._on_command, command_qos())
        self.create_subscription(PtzState, "ptz/state", self._on_state, 10)

    def _on_change(self, changed: dict[str, Any]) -> None:
        self.settings = config_from_params(AxisPtzAdapterConfig, self.params)

    def _on_state(self, state: PtzState) -> None:
        if usable_value(state.pan) and usable_value(state.tilt):
            self.pose = CameraPose(state.pan, state.tilt, 0.0, 0.0, 1.0)

    def _on_command(self, msg: PtzCommand) -> None:
        command = command_of(msg)
        if command is None:
            values = (msg.pan, msg.tilt, msg.pan_rate, msg.tilt_rate)
            self.problems.report(
                "unusable command",
                f"sent a stop for a PtzCommand with mode {msg.mode} and values {values}",
            )
            command = Command(CommandMode.HOLD)
        settings = self.settings
        pan, tilt = velocity_only(
            command, self.pose, self.mapping, settings.position_gain, settings.max_rate
        )
        self.velocity_pub.publish(Ptz(pan=pan, tilt=tilt, zoom=0.0))
        self.sent = True

    def destroy_node(self) -> None:
        if self.sent and not self.stopping.is_set():
            self.velocity_pub.publish(Ptz(pan=0.0, tilt=0.0, zoom=0.0))  # the camera stops now
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run_node(AxisPtzAdapterNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
