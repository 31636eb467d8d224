"""The ptz_controller node with hostile pan-tilt states and targets: it keeps running, answers every
image, logs one line per cause, and answers good messages afterwards exactly as before."""

from __future__ import annotations

import math

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from hostile_messages import (  # noqa: E402
    Field,
    HostileSource,
    all_finite,
    assert_unchanged_by_hostile_messages,
    feed_hostile,
    record_publishes,
)
from node_harness import NodeHarness  # noqa: E402
from ptz_messages import state_msg, target_msg  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402

from tracker_msgs.msg import PtzCommand, PtzState, Target  # noqa: E402
from tracker_msgs_py.codec import result_qos, stamp_to_ns  # noqa: E402
from tracker_ptz_sim.control.controller import ControlState  # noqa: E402
from tracker_ptz_sim.control.ptz_controller_node import PtzControllerNode  # noqa: E402

pytestmark = pytest.mark.ros
NS = 100_000_000  # 10 fps
F = 440.0  # px/rad


@pytest.fixture
def harness():
    h = NodeHarness(
        PtzControllerNode,
        inputs={"ptz/state": (PtzState, 50), "target": (Target, 50)},
        outputs={"ptz/command": (PtzCommand, 50)},
        mode="servo",
        state_timeout=0.3,
    )
    yield h
    h.close()


def commands(h):
    return h.received["ptz/command"]


def answer(h, state, target):
    """Send a state and its image's target; the command that answers them."""
    count = len(commands(h))
    if state is not None:
        h.publish("ptz/state", state)
    h.publish("target", target)
    h.spin_until(lambda: len(commands(h)) > count)
    return commands(h)[-1]


def good_run(h, first_frame):
    """Ten frames of a target right of centre; the commands as (stamp, mode, rates)."""
    out = []
    for k in range(first_frame, first_frame + 10):
        command = answer(h, state_msg(k * NS), target_msg(k * NS, x=430.0 + 3 * k))
        out.append((stamp_to_ns(command.header.stamp), command.mode, command.pan_rate))
    return out


def clean_run(first_frame):
    """`good_run` on a controller of its own that never saw a bad message."""
    reference = NodeHarness(
        PtzControllerNode,
        inputs={"ptz/state": (PtzState, 50), "target": (Target, 50)},
        outputs={"ptz/command": (PtzCommand, 50)},
        mode="servo",
    )
    try:
        return good_run(reference, first_frame)
    finally:
        reference.close()


def test_good_states_and_targets_give_velocity_commands_to_the_right(harness):
    run = good_run(harness, 10)
    assert all(mode == PtzCommand.MODE_VELOCITY for _, mode, _ in run)
    assert all(rate < 0 for _, _, rate in run)  # target right of centre: pan right (negative)
    assert [stamp for stamp, _, _ in run] == [k * NS for k in range(10, 20)]


@pytest.mark.parametrize(
    ("focal", "window", "cause"),
    [
        (0.0, (252.0, 156.0, 264.0, 264.0), "focal_length"),  # the message default: unset
        (math.nan, (252.0, 156.0, 264.0, 264.0), "focal_length"),
        (-F, (252.0, 156.0, 264.0, 264.0), "focal_length"),
        (F, (math.nan, 156.0, 264.0, 264.0), "window"),
        (F, (252.0, 156.0, 0.0, 264.0), "window"),
    ],
)
def test_an_unusable_state_is_answered_with_hold_and_changes_nothing(
    harness, capfd, focal, window, cause
):
    for k in range(3):
        command = answer(harness, state_msg(k * NS, focal, window), target_msg(k * NS))
        assert command.mode == PtzCommand.MODE_HOLD and stamp_to_ns(command.header.stamp) == k * NS
    assert harness.node.problems.total == 3 and len(harness.node.problems.counts) == 1
    assert good_run(harness, 10) == clean_run(10)
    logged = [line for line in capfd.readouterr().err.splitlines() if "unusable PtzState" in line]
    assert len(logged) == 1 and cause in logged[0]


def test_a_target_stamped_back_in_time_is_not_paired_with_an_unrelated_state(harness):
    good_run(harness, 10)
    # A target from before every state kept: it must not be steered by the state of frame 19.
    command = answer(harness, None, target_msg(2 * NS, x=700.0))
    assert command.mode == PtzCommand.MODE_HOLD and stamp_to_ns(command.header.stamp) == 2 * NS
    assert harness.node.problems.count("no ptz/state for a target") == 1


def test_targets_before_any_state_are_answered_with_hold_and_a_warning(harness, capfd):
    for k in range(3):
        command = answer(harness, None, target_msg(k * NS))
        assert command.mode == PtzCommand.MODE_HOLD and stamp_to_ns(command.header.stamp) == k * NS
    logged = [line for line in capfd.readouterr().err.splitlines() if "no ptz/state" in line]
    assert len(logged) == 1 and "publishing ptz/state" in logged[0]
    assert harness.node.problems.count("no ptz/state yet") == 3


def test_a_state_that_comes_after_its_target_is_still_used(harness):
    harness.publish("target", target_msg(5 * NS))
    harness.spin_for(0.1)
    assert commands(harness) == []  # waits for the state of its image
    harness.publish("ptz/state", state_msg(5 * NS))
    harness.spin_until(lambda: len(commands(harness)) == 1)
    assert commands(harness)[0].mode == PtzCommand.MODE_VELOCITY


def test_a_repeated_target_is_answered_once(harness):
    answer(harness, state_msg(NS), target_msg(NS))
    harness.publish("target", target_msg(NS))
    harness.spin_until(lambda: harness.node.problems.count("repeat target stamp") == 1)
    harness.spin_for(0.1)
    assert len(commands(harness)) == 1


def test_a_restarted_source_starts_a_new_epoch(harness):
    first = good_run(harness, 300)
    # The source restarts at frame 0: states and targets jump back; control starts afresh and
    # gives what a fresh controller gives.
    again = good_run(harness, 0)
    assert harness.node.target_order.epochs == 1
    assert [mode for _, mode, _ in again] == [mode for _, mode, _ in first]
    assert [stamp for stamp, _, _ in again] == [k * NS for k in range(10)]


def test_an_unusable_locked_target_is_answered_with_hold_and_changes_nothing(harness, capfd):
    """Locked targets with x NaN, vx inf, predicted_x NaN, lead_time NaN or x = 1e308, mixed in
    between good frames (stamped half a frame after one, even 1000 s ahead): each answered with
    HOLD, one log line for the cause, and every good frame's command is the clean run's."""

    def spoiled(stamp_ns, field):
        target = target_msg(stamp_ns)
        if field == "predicted_x":
            target.predicted_x = math.nan
        elif field == "lead_time":
            target.lead_time = math.nan
        elif field == "vx":
            target.track.vx = math.inf
        else:
            target.track.x = 1e308 if field == "huge x" else math.nan
        return target

    bad = ["x", "vx", "predicted_x", "lead_time", "huge x"]
    mixed = []
    for k in range(10, 20):
        command = answer(harness, state_msg(k * NS), target_msg(k * NS, x=430.0 + 3 * k))
        mixed.append((stamp_to_ns(command.header.stamp), command.mode, command.pan_rate))
        if bad:
            stamp = k * NS + NS // 2 if len(bad) > 1 else 1000 * 10 * NS
            held = answer(harness, None, spoiled(stamp, bad.pop(0)))
            assert held.mode == PtzCommand.MODE_HOLD and stamp_to_ns(held.header.stamp) == stamp
    assert harness.node.problems.counts == {"unusable target": 5}
    assert mixed == clean_run(10)
    logged = [line for line in capfd.readouterr().err.splitlines() if "unusable target" in line]
    assert len(logged) == 1 and "x is nan" in logged[0]


def test_targets_that_stop_are_answered_with_hold_once_two_states_confirm_it(harness, capfd):
    """The tracker goes quiet while states keep coming: past target_timeout (1 s) every image is
    acknowledged with HOLD, the first once the next state confirms the timeout, with one line."""
    good_run(harness, 0)  # the last target at frame 9
    for k in range(10, 25):
        harness.publish("ptz/state", state_msg(k * NS))
    harness.spin_until(lambda: len(commands(harness)) == 10 + 5)
    harness.spin_for(0.1)
    held = commands(harness)[10:]
    assert [stamp_to_ns(c.header.stamp) for c in held] == [k * NS for k in range(20, 25)]
    assert all(c.mode == PtzCommand.MODE_HOLD for c in held)
    logged = [line for line in capfd.readouterr().err.splitlines() if "no target for" in line]
    assert len(logged) == 1 and "holding the camera" in logged[0]


def test_when_targets_return_after_stopping_the_control_carries_on_where_it_was(harness):
    """The detector restarts: while targets are stopped the control keeps tracking (no reset, no
    sweep), and after they return it holds (for up to lost_scan_time) until the tracker has taken
    the target up again, then follows it."""
    good_run(harness, 0)
    for k in range(10, 25):
        harness.publish("ptz/state", state_msg(k * NS))
    harness.spin_until(lambda: len(commands(harness)) == 15)
    assert harness.node.controller.state is ControlState.TRACK
    unlocked = [
        answer(harness, state_msg(k * NS), target_msg(k * NS, locked=False)) for k in (25, 26)
    ]
    assert [c.mode for c in unlocked] == [PtzCommand.MODE_HOLD] * 2
    locked = answer(harness, state_msg(27 * NS), target_msg(27 * NS))
    assert locked.mode == PtzCommand.MODE_VELOCITY


def test_images_that_resume_after_a_gap_are_not_taken_for_stopped_targets(harness, capfd):
    """The stream drops for 3 s and returns: the states of the first images after the gap come
    before their targets, yet they are past target_timeout only because there were no images.
    No reset: until the tracker has taken the target up again (unlocked targets, for up to
    lost_scan_time) the camera holds instead of scanning, and then follows it; a later loss is
    scanned for as usual."""
    good_run(harness, 0)  # the last target at frame 9
    for k in (40, 41, 42):  # the tracker's answers to these are still on their way
        harness.publish("ptz/state", state_msg(k * NS))
    harness.spin_for(0.2)
    assert len(commands(harness)) == 10
    unlocked = [answer(harness, None, target_msg(k * NS, locked=False)) for k in (40, 41, 42)]
    assert [c.mode for c in unlocked] == [PtzCommand.MODE_HOLD] * 3
    locked = [answer(harness, state_msg(k * NS), target_msg(k * NS)) for k in range(43, 55)]
    assert [c.mode for c in locked] == [PtzCommand.MODE_VELOCITY] * 12
    assert not [line for line in capfd.readouterr().err.splitlines() if "no target for" in line]
    # lost again later, with images flowing: a loss, scanned for (positions)
    lost = answer(harness, state_msg(55 * NS), target_msg(55 * NS, locked=False))
    assert lost.mode == PtzCommand.MODE_POSITION
    # the tracker does go quiet: the timeout counts from the last target, as before
    for k in range(56, 70):
        harness.publish("ptz/state", state_msg(k * NS))
    harness.spin_until(lambda: len(commands(harness)) == 26 + 4)
    held = commands(harness)[26:]
    assert [stamp_to_ns(c.header.stamp) for c in held] == [k * NS for k in range(66, 70)]
    assert all(c.mode == PtzCommand.MODE_HOLD for c in held)


def test_the_units_measured_latency_becomes_the_unit_latency_parameter(capfd):
    """ptz/unit_latency (a driver's calibration; transient local, so also sent before the
    controller started) sets unit_latency as a `ros2 param set` would; a value out of its range
    is refused with one line and changes nothing."""
    h = NodeHarness(
        PtzControllerNode,
        inputs={"ptz/unit_latency": (Float64, result_qos())},
        outputs={"ptz/command": (PtzCommand, 50)},
    )
    try:
        h.publish("ptz/unit_latency", Float64(data=0.25))
        h.spin_until(lambda: h.node.controller.config.unit_latency == 0.25)
        assert h.node.get_parameter("unit_latency").value == 0.25
        h.publish("ptz/unit_latency", Float64(data=-1.0))
        h.spin_until(lambda: h.node.problems.count("unusable unit latency") == 1)
        assert h.node.controller.config.unit_latency == 0.25
    finally:
        h.close()
    logged = [line for line in capfd.readouterr().err.splitlines() if "unit_latency" in line]
    assert len(logged) == 2 and "as the unit measured it" in logged[0], logged


def test_a_lone_state_stamped_far_ahead_changes_nothing(harness, capfd):
    """One PtzState 1000 s ahead between good frames: no HOLD for it, no reset of the control, one
    line when the states return to their time, and every good frame's command is the clean run's."""
    mixed = []
    for k in range(10, 20):
        command = answer(harness, state_msg(k * NS), target_msg(k * NS, x=430.0 + 3 * k))
        mixed.append((stamp_to_ns(command.header.stamp), command.mode, command.pan_rate))
        if k == 11:
            harness.publish("ptz/state", state_msg(10_000 * NS + 2 * NS))
            harness.spin_for(0.1)
    assert len(commands(harness)) == 10
    assert mixed == clean_run(10)
    logged = [line for line in capfd.readouterr().err.splitlines() if "jumped back" in line]
    assert len(logged) == 1 and "forgot the 1 state" in logged[0]


def test_a_state_stamped_before_zero_is_ignored_with_one_line(harness, capfd):
    bad = state_msg(0)
    bad.header.stamp.sec = -3
    harness.publish("ptz/state", bad)
    harness.spin_until(lambda: harness.node.problems.count("invalid state stamp") == 1)
    assert harness.node.states == {}
    assert good_run(harness, 10) == clean_run(10)


TARGET_FIELDS = [
    Field("track.x"),
    Field("track.y"),
    Field("track.vx"),
    Field("track.vy"),
    Field("predicted_x"),
    Field("predicted_y"),
    Field("lead_time"),
    Field("track.bbox.height", positive=True),
]
STATE_FIELDS = [
    Field("pan"),
    Field("tilt"),
    Field("focal_length", positive=True),
    Field("window.x"),
    Field("window.y"),
    Field("window.width", positive=True),
    Field("window.height", positive=True),
]


def command_values(command):
    return (command.pan, command.tilt, command.pan_rate, command.tilt_rate, command.zoom)


def test_hundreds_of_hostile_messages_change_no_good_answer_and_no_command_is_non_finite(capfd):
    """Seeded: 20 good frames of a walking target, and after each 15 hostile targets (locked) or
    states, a field non-finite, huge or negative, stamped between frames, far ahead, back in
    time, on the last frame or before zero. The good frames' commands are the clean run's, every
    command published is finite, the node lives, and each cause is logged once."""
    rng = np.random.default_rng(67)
    sources = [
        HostileSource("target", lambda ns: target_msg(ns, x=470.0), TARGET_FIELDS),
        HostileSource("ptz/state", state_msg, STATE_FIELDS),
    ]

    def run(hostile: bool) -> tuple[list, dict[str, int]]:
        h = NodeHarness(
            PtzControllerNode,
            inputs={"ptz/state": (PtzState, 50), "target": (Target, 50)},
            outputs={"ptz/command": (PtzCommand, 500)},
            mode="servo",
            zoom_control=True,
        )
        published = record_publishes(h.node.command_pub)
        try:
            good = []
            for k in range(20):
                stamp = k * NS
                h.feed("ptz/state", state_msg(stamp))
                h.feed("target", target_msg(stamp, x=430.0 + 3 * k))
                good.append(published[-1])
                assert stamp_to_ns(good[-1].header.stamp) == stamp
                if hostile:
                    feed_hostile(h, rng, sources, stamp, NS)
            assert all(all_finite(command_values(c)) for c in published)
            answers = [(stamp_to_ns(c.header.stamp), c.mode, *command_values(c)) for c in good]
            return answers, dict(h.node.problems.counts)
        finally:
            h.close()

    assert_unchanged_by_hostile_messages(run, capfd, counted_at_least=200)


def test_the_followed_target_is_also_a_ray_in_the_cameras_optical_frame():
    """A locked target right of and below the view's centre: a point 1 m along its ray, in the
    images' frame, stamped like its image (x right, y down, z forward)."""
    import math

    from geometry_msgs.msg import PointStamped

    from tracker_msgs_py.codec import result_qos

    h = NodeHarness(
        PtzControllerNode,
        inputs={"ptz/state": (PtzState, 50), "target": (Target, 50)},
        outputs={"target_ray": (PointStamped, result_qos())},
        mode="servo",
    )
    try:
        h.spin_until(lambda: h.node.ray_pub.get_subscription_count() == 1)
        h.feed("ptz/state", state_msg(3 * NS))  # window centre (384, 288), 440 px/rad
        h.feed("target", target_msg(3 * NS, x=384.0 + 44.0, y=288.0 + 22.0))
        h.spin_until(lambda: len(h.received["target_ray"]) == 1)
        (ray,) = h.received["target_ray"]
        assert (
            ray.header.frame_id == "ptz_camera_optical" and stamp_to_ns(ray.header.stamp) == 3 * NS
        )
        right, down = 0.1, 0.05  # rad: 44 and 22 scene px at 440 px/rad
        assert ray.point.x == pytest.approx(math.cos(down) * math.sin(right), abs=1e-9)
        assert ray.point.y == pytest.approx(math.sin(down), abs=1e-9)
        assert math.hypot(ray.point.x, ray.point.y, ray.point.z) == pytest.approx(1.0)
    finally:
        h.close()
