"""The ptz_camera node with hostile scenes and commands: one log line per distinct cause, nothing
outside the scene, and a restarted source (stamps going back) is a new epoch, not a dead camera."""

from __future__ import annotations

import math

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy")

from hostile_messages import (  # noqa: E402
    HOSTILE_PER_FRAME,
    Field,
    all_finite,
    assert_unchanged_by_hostile_messages,
    hostile_stamp,
    record_publishes,
    spoil,
    unreadable_image,
)
from node_harness import NodeHarness  # noqa: E402
from ptz_messages import state_values  # noqa: E402
from sensor_msgs.msg import Image, JointState  # noqa: E402

from tracker_msgs.msg import PtzCommand, PtzState  # noqa: E402
from tracker_msgs_py.codec import array_to_image, image_qos, ns_to_stamp, result_qos  # noqa: E402
from tracker_ptz_sim.simulation.ptz_camera_node import PtzCameraNode  # noqa: E402

pytestmark = pytest.mark.ros
NS = 100_000_000


@pytest.fixture
def harness():
    h = NodeHarness(
        PtzCameraNode,
        inputs={"scene/image_raw": (Image, image_qos(True)), "ptz/command": (PtzCommand, 50)},
        outputs={"ptz/state": (PtzState, 50), "camera/image_raw": (Image, image_qos(True))},
        reliable_images=True,
    )
    yield h
    h.close()


def scene(stamp_ns, width=320, height=240):
    pixels = np.random.default_rng(stamp_ns % 1000).integers(0, 255, (height, width, 3), np.uint8)
    return array_to_image(pixels, "bgr8", ns_to_stamp(stamp_ns), "scene")


def send_scene(h, stamp_ns, **size):
    count = len(h.received["ptz/state"])
    h.publish("scene/image_raw", scene(stamp_ns, **size))
    h.spin_until(lambda: len(h.received["ptz/state"]) > count)
    return h.received["ptz/state"][-1]


def command(stamp_ns, mode=PtzCommand.MODE_VELOCITY, pan_rate=0.0):
    msg = PtzCommand(mode=mode, pan_rate=pan_rate)
    msg.header.stamp = ns_to_stamp(stamp_ns)
    return msg


def replace_zoom(msg, zoom):
    msg.zoom = zoom
    return msg


def send_command(h, stamp_ns, pan_rate):
    """A velocity command, delivered before the next scene image is sent."""
    count = h.node.commands_received
    h.publish("ptz/command", command(stamp_ns, pan_rate=pan_rate))
    h.spin_until(lambda: h.node.commands_received > count)


def inside(window, width, height):
    return (
        window.x >= 0
        and window.y >= 0
        and window.x + window.width <= width
        and window.y + window.height <= height
    )


@pytest.mark.parametrize("size", [(1, 1), (2, 2), (12, 9)])
def test_a_scene_too_small_for_a_view_is_dropped_with_one_warning(harness, capfd, size):
    width, height = size
    for k in range(3):
        harness.publish("scene/image_raw", scene(k * NS, width, height))
    harness.spin_until(lambda: harness.node.problems.count("scene too small") == 3)
    assert harness.received["ptz/state"] == []
    logged = [line for line in capfd.readouterr().err.splitlines() if "too small" in line]
    assert len(logged) == 1 and f"{width}x{height}" in logged[0]
    state = send_scene(harness, 5 * NS)  # a good scene afterwards works as on a fresh camera
    assert inside(state.window, 320, 240) and state.window.height == 110


def test_the_window_stays_inside_small_scenes_at_every_zoom():
    from tracker_ptz_sim.simulation.camera_model import PtzCameraModel, PtzCommand, PtzConfig

    for width, height in [(18, 18), (20, 40), (64, 48)]:
        model = PtzCameraModel(PtzConfig(max_zoom=50.0), width, height)
        for zoom in (1.0, 3.0, 50.0):
            model.command(PtzCommand(0.0, "position", 9.0, -9.0, zoom=zoom))
            window = model.advance(5.0 + zoom).window
            assert inside(window, width, height) and window.width >= 2


def test_different_bad_commands_each_get_their_own_warning(harness, capfd):
    send_scene(harness, 0)
    send_scene(harness, NS)
    harness.publish("ptz/command", command(0, pan_rate=math.inf))
    harness.publish("ptz/command", command(0, mode=7))
    harness.publish("ptz/command", command(0, pan_rate=math.inf))
    harness.publish("ptz/command", command(50 * NS))  # after the latest image
    negative = command(0, pan_rate=0.3)
    negative.header.stamp.sec = -3  # before zero: it answers no image
    harness.publish("ptz/command", negative)
    for zoom in (math.inf, -5.0):
        harness.publish("ptz/command", replace_zoom(command(NS, pan_rate=0.3), zoom))
    harness.spin_until(lambda: harness.node.problems.total == 7)
    err = capfd.readouterr().err
    assert err.count("command with values (0.0, 0.0, inf, 0.0)") == 1
    assert err.count("unknown mode 7") == 1
    assert err.count("after the latest scene image") == 1
    assert err.count("command stamped -3.000 s") == 1 and err.count("with zoom inf") == 1
    assert harness.node.problems.counts == {
        "unusable command values": 2,
        "unknown command mode": 1,
        "command from the future": 1,
        "negative stamp": 1,
        "invalid zoom": 2,
    }
    # The camera still acts on good commands.
    send_command(harness, NS, pan_rate=-1.0)
    before = harness.received["ptz/state"][-1].pan
    after = send_scene(harness, 2 * NS).pan
    assert after < before


def test_a_dropped_scene_image_far_ahead_moves_no_clock(harness, capfd):
    """An image of an unsupported encoding stamped 1000 s ahead is dropped with one warning, and
    the next good image is the next frame (no new epoch): the camera keeps its pan rate."""
    send_scene(harness, 10 * NS)
    send_command(harness, 10 * NS, pan_rate=0.5)
    moving = send_scene(harness, 11 * NS)
    depth = Image(height=2, width=2, encoding="16UC1", step=4, data=bytes(8))
    depth.header.stamp = ns_to_stamp(1011 * NS)
    harness.publish("scene/image_raw", depth)
    harness.spin_until(lambda: harness.node.problems.total == 1)
    later = send_scene(harness, 12 * NS)
    assert harness.node.scene_order.epochs == 0 and "jumped back" not in capfd.readouterr().err
    assert later.moving and later.pan > moving.pan


def test_repeated_scene_images_are_dropped_and_a_jump_back_is_a_new_epoch(harness):
    send_scene(harness, 10 * NS)
    send_command(harness, 10 * NS, pan_rate=0.5)  # turning left
    moving = send_scene(harness, 11 * NS)
    harness.publish("scene/image_raw", scene(11 * NS))  # a lockstep re-send
    harness.spin_for(0.1)
    assert len(harness.received["ptz/state"]) == 2 and harness.node.repeated_images == 1
    # The source restarted: stamps start again at 0. The camera answers, keeps its pose and
    # drops the old epoch's velocity command.
    restarted = send_scene(harness, 0)
    assert moving.moving and moving.pan > 0
    assert restarted.header.stamp.sec == 0 and restarted.pan == pytest.approx(moving.pan)
    later = send_scene(harness, NS)
    assert later.pan == pytest.approx(restarted.pan) and not later.moving
    send_command(harness, NS, pan_rate=0.5)
    assert send_scene(harness, 2 * NS).pan > later.pan  # commands of the new epoch act


def test_malformed_images_of_one_encoding_are_told_apart(harness, capfd):
    short = scene(0)
    short.data = bytes(short.data[:100])
    narrow = scene(NS)
    narrow.step = 10
    for msg in (short, narrow, scene(2 * NS)):
        harness.publish("scene/image_raw", msg)
    harness.spin_until(lambda: len(harness.received["ptz/state"]) == 1)
    err = capfd.readouterr().err
    assert "fewer bytes than step x height" in err and "step is shorter than a row" in err


def test_pipelined_lockstep_waits_only_for_the_command_its_delay_needs():
    """command_delay_frames 2: image n waits for the answer to image n - 2, not n - 1, and the
    images that arrive meanwhile wait in order."""
    h = NodeHarness(
        PtzCameraNode,
        inputs={"scene/image_raw": (Image, image_qos(True)), "ptz/command": (PtzCommand, 50)},
        outputs={"ptz/state": (PtzState, 50), "camera/image_raw": (Image, image_qos(True))},
        reliable_images=True,
        lockstep=True,
        command_delay_frames=2,
    )
    try:
        states = h.received["ptz/state"]
        send_scene(h, 10 * NS)
        send_scene(h, 11 * NS)  # needs no command: none answers an image two before it
        h.publish("scene/image_raw", scene(12 * NS))
        h.publish("scene/image_raw", scene(13 * NS))
        h.spin_for(0.3)
        assert len(states) == 2, "image 12 waits for the answer to image 10"
        send_command(h, 10 * NS, pan_rate=0.5)
        h.spin_until(lambda: len(states) == 3)
        h.spin_for(0.2)
        assert len(states) == 3, "image 13 waits for the answer to image 11"
        send_command(h, 11 * NS, pan_rate=0.5)
        h.spin_until(lambda: len(states) == 4)
        stamps = [s.header.stamp.sec * 10**9 + s.header.stamp.nanosec for s in states]
        assert stamps == [10 * NS, 11 * NS, 12 * NS, 13 * NS]
        assert [s.pan > 0 for s in states] == [False, False, True, True]
    finally:
        h.close()


COMMAND_FIELDS = [
    Field("pan"),
    Field("tilt"),
    Field("pan_rate"),
    Field("tilt_rate"),
    Field("zoom", positive=True),
]


def good_command(stamp_ns, k=0):
    """Frame k's command: a slow pan with a zoom step now and then, a position move at times."""
    if k % 7 == 6:
        msg = command(stamp_ns, mode=PtzCommand.MODE_POSITION)
        msg.pan, msg.tilt = 0.05 * (k % 3), -0.02
        return msg
    msg = command(stamp_ns, pan_rate=0.2 * math.sin(0.4 * k))
    msg.tilt_rate, msg.zoom = 0.05, (1.0 + 0.1 * (k % 4)) if k % 5 == 0 else 0.0
    return msg


JOINT_COMMAND_FIELDS = [
    Field("position[0]", nan_means_unset=True),
    Field("position[1]", nan_means_unset=True),
    Field("velocity[0]", nan_means_unset=True),
    Field("velocity[1]", nan_means_unset=True),
    Field("position[2]", positive=True, nan_means_unset=True),
]


def good_joint_command(stamp_ns, k=0):
    """`good_command` as a real unit's driver takes it: a JointState of pan, tilt and zoom."""
    suite = good_command(stamp_ns, k)
    msg = JointState(name=["pan_joint", "tilt_joint", "zoom"])
    msg.header.stamp = suite.header.stamp
    zoom = suite.zoom if suite.zoom > 0 else math.nan
    if suite.mode == PtzCommand.MODE_POSITION:
        msg.position = [suite.pan, suite.tilt, zoom]
        msg.velocity = [math.nan] * 3  # not commanded
    else:
        msg.position = [math.nan, math.nan, zoom]
        msg.velocity = [suite.pan_rate, suite.tilt_rate, math.nan]
    return msg


@pytest.mark.parametrize("interface", ["suite", "standard"])
def test_hundreds_of_hostile_messages_change_no_good_answer_and_nothing_non_finite_leaves(
    capfd, interface
):
    """Seeded: 20 good scene images, each answered with a command (a PtzCommand, or for a real
    unit's interface a JointState); after each, 15 hostile commands (a field non-finite, huge or
    a negative zoom) or unreadable scene images, stamped between frames, far ahead, back in time,
    on the last frame, the next frame's or before zero. The camera's states, joint states and
    views for the good images are the clean run's, every state and joint state it publishes is
    finite, and each cause is logged once."""
    rng = np.random.default_rng(67)
    standard = interface == "standard"
    topic, make, fields = (
        ("ptz/joint_command", good_joint_command, JOINT_COMMAND_FIELDS)
        if standard
        else ("ptz/command", good_command, COMMAND_FIELDS)
    )

    def run(hostile: bool):
        h = NodeHarness(
            PtzCameraNode,
            inputs={
                "scene/image_raw": (Image, image_qos(True)),
                topic: (JointState if standard else PtzCommand, result_qos(late_joiners=False)),
            },
            outputs={"ptz/joint_states": (JointState, 50)},
            reliable_images=True,
            interface=interface,
            zoom_joint="zoom" if standard else "",
        )
        states = [] if standard else record_publishes(h.node.state_pub)
        joints = record_publishes(h.node.joint_pub)
        views = record_publishes(h.node.view_pub)
        try:
            answers = []
            for k in range(20):
                stamp = k * NS
                h.feed("scene/image_raw", scene(stamp))
                answers.append(
                    (
                        state_values(states[-1]) if states else (),
                        tuple(joints[-1].position),
                        tuple(joints[-1].velocity),
                        bytes(views[-1].data),
                    )
                )
                h.feed(topic, make(stamp, k))
                for _ in range(HOSTILE_PER_FRAME if hostile else 0):
                    if rng.integers(4):
                        msg, _ = spoil(rng, make(stamp, k), fields, stamp, NS)
                        h.feed(topic, msg)
                    else:
                        h.feed(
                            "scene/image_raw",
                            unreadable_image(rng, scene(0), hostile_stamp(rng, stamp, NS)),
                        )
            assert all(all_finite(state_values(s)) for s in states)
            assert all(all_finite([*j.position, *j.velocity]) for j in joints)
            return answers, dict(h.node.problems.counts)
        finally:
            h.close()

    assert_unchanged_by_hostile_messages(run, capfd, counted_at_least=250)
