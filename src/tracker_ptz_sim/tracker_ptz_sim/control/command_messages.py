"""tracker_msgs/PtzCommand as the controller's `Command` and back: one mapping of the modes for
the controller, which publishes them, and for the adapters that drive real units from them."""

from __future__ import annotations

from typing import Any

from tracker_msgs.msg import PtzCommand
from tracker_msgs_py.codec import usable_value
from tracker_ptz_sim.control.controller import Command, CommandMode

MODES = {
    PtzCommand.MODE_POSITION: CommandMode.POSITION,
    PtzCommand.MODE_VELOCITY: CommandMode.VELOCITY,
    PtzCommand.MODE_HOLD: CommandMode.HOLD,
}
MODE_VALUES = {mode: value for value, mode in MODES.items()}


def command_of(msg: PtzCommand) -> Command | None:
    """The message's command, or None for an unknown mode or a value that is not usable (the
    caller stops the unit and reports it)."""
    mode = MODES.get(msg.mode)
    values = (msg.pan, msg.tilt, msg.pan_rate, msg.tilt_rate)
    if mode is None or not all(usable_value(v) for v in values):
        return None
    return Command(mode, *values, zoom=msg.zoom)


def command_msg(command: Command, header: Any) -> PtzCommand:
    msg = PtzCommand(header=header, mode=MODE_VALUES[command.mode])
    msg.pan, msg.tilt = command.pan, command.tilt
    msg.pan_rate, msg.tilt_rate = command.pan_rate, command.tilt_rate
    msg.zoom = command.zoom  # 0: keep the current zoom
    return msg
