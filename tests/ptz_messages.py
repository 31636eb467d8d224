"""PtzState and Target messages for the controller's tests: a 264 px window of a 440 px/rad scene,
and a locked target in it; `state_values` to compare PtzStates."""

from __future__ import annotations

from tracker_msgs.msg import PtzState, Target
from tracker_msgs_py.codec import ns_to_stamp

F = 440.0  # px/rad


def state_msg(stamp_ns, focal=F, window=(252.0, 156.0, 264.0, 264.0), pan=0.0):
    state = PtzState(pan=pan, tilt=0.0, zoom=1.0, focal_length=focal)
    state.window.x, state.window.y, state.window.width, state.window.height = window
    state.header.stamp = ns_to_stamp(stamp_ns)
    state.header.frame_id = "scene"
    return state


def target_msg(stamp_ns, x=430.0, y=300.0, locked=True):
    target = Target(locked=locked, lead_time=0.1, predicted_x=x + 2.0, predicted_y=y)
    target.track.x, target.track.y, target.track.vx, target.track.vy = x, y, 20.0, 0.0
    target.header.stamp = ns_to_stamp(stamp_ns)
    return target


def state_values(state):
    """A PtzState's numbers: motion, zoom, window and focal length."""
    window = state.window
    motion = (state.pan, state.tilt, state.pan_rate, state.tilt_rate, state.zoom)
    return (*motion, window.x, window.y, window.width, window.height, state.focal_length)
