"""The surveillance graph behind a camera that speaks only sensor_msgs, as a real pan-tilt unit's
drivers do (config/standard_graph.yaml): ptz_camera stands in for the drivers (camera/image_raw,
camera/camera_info, ptz/joint_states out; JointState commands in), ptz_state_bridge makes the
suite's ptz/state from them, and the controller steers the unit with JointState commands."""

from __future__ import annotations

import pytest
from demo_runs import ONE_WALKER, motion_only_settings, run_demo

pytestmark = [pytest.mark.ros, pytest.mark.slow]

WALKER_PAN = -0.3  # rad: the walker's first position, x = 320 - 280 px/rad * pan = 404 (its 411)


FLIR_STYLE = [
    f"{node}.joint_command_style=positions_with_speeds" for node in ("ptz_camera", "ptz_controller")
]


def _run(tmp_path_factory, name, *settings):
    from tracker_ptz_sim.evaluation import run_report
    from tracker_ptz_sim.simulation.scene_files import write_scene
    from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

    root = tmp_path_factory.mktemp(name)
    paths = write_scene(generate_scene(SceneConfig(**ONE_WALKER)), root / "scene")
    out = root / "run"
    settings = [f"ptz_camera.initial_pan={WALKER_PAN}", *motion_only_settings(), *settings]
    run_demo(paths.video, out, *settings, graph="standard")
    return paths, out, run_report.collect(out / "bag")


@pytest.fixture(scope="module")
def standard_run(tmp_path_factory):
    """One person-sized object walking with two turns (the surveillance graph test's scene; a
    round object, so the graph runs motion-only, as config/motion.yaml makes it), the unit
    starting pointed at it: this test is about steering through standard messages, and the
    search's single pass over this walker (it walks up out of the sweep's band within 8 frames)
    is too short to confirm it for a pinhole camera's 3 % narrower view."""
    return _run(tmp_path_factory, "standard")


def _follow(run):
    from tracker_ptz_sim.evaluation import metrics
    from tracker_ptz_sim.evaluation.scoring import windows_and_targets

    paths, _, frames = run
    windows, targets = windows_and_targets(frames)
    return metrics.follow_scores(metrics.load_mot(paths.gt), windows, targets)


def test_the_unit_is_steered_onto_the_walker_with_joint_commands(standard_run):
    follow = _follow(standard_run)
    assert follow.followed_id == 1
    assert follow.frames_after_lock >= 100
    assert follow.inside_share >= 0.95, follow
    assert follow.mean_center_error_share <= 0.10, follow


def test_every_image_gets_a_bridged_state_and_a_joint_command(standard_run):
    from tracker_msgs_py.codec import stamp_to_ns
    from tracker_ptz_sim.evaluation.recording import read_bag, topic_counts

    _, out, frames = standard_run
    counts = topic_counts(out / "bag")
    images = counts["/camera/image_raw/compressed"]
    assert images == len(frames) == 150
    assert counts["/ptz/state"] == counts["/camera/camera_info"] == images
    # one command per image, plus the stop the controller sends when it shuts down
    assert images <= counts["/ptz/joint_command"] <= images + 1
    joints = {
        stamp_to_ns(m.header.stamp): m for _, _, m in read_bag(out / "bag", {"/ptz/joint_states"})
    }
    for _, _, state in read_bag(out / "bag", {"/ptz/state"}):
        measured = joints[stamp_to_ns(state.header.stamp)]
        assert (state.pan, state.tilt) == (measured.position[0], measured.position[1])
        # the window is centred where the pan-tilt angles point in the scene
        center_x = state.window.x + state.window.width / 2
        assert center_x == pytest.approx(320.0 - state.focal_length * state.pan, abs=0.5)
    commands = [m for _, _, m in read_bag(out / "bag", {"/ptz/joint_command"})]
    assert all(list(c.name) == ["pan_joint", "tilt_joint"] for c in commands)
    turning = [c for c in commands if len(c.velocity) and any(v != 0.0 for v in c.velocity)]
    assert len(turning) >= 50  # it did steer


def test_a_flir_ptu_like_unit_follows_the_walker_on_positions_with_speeds(
    standard_run, tmp_path_factory
):
    """The stand-in reads its JointState commands as the FLIR PTU driver does (two positions, two
    speeds, by index) and the controller sends that form: the walker is followed as well as with
    velocity commands (in the runs so far, identically to the pixel: a goal 0.5 s ahead is not
    reached within the frame, so the unit turns at the commanded speed, as with the rate)."""
    from unit_contracts import flir_ptu_contract_problem

    from tracker_ptz_sim.control.unit_joints import (
        CommandStyle,
        JointCommand,
        UnitSettings,
    )
    from tracker_ptz_sim.evaluation.recording import read_bag

    flir = _run(tmp_path_factory, "flir", *FLIR_STYLE)
    follow, velocity = _follow(flir), _follow(standard_run)
    assert follow.followed_id == 1 and follow.frames_after_lock >= 100
    assert follow.inside_share >= 0.95, follow
    assert follow.mean_center_error_share <= 1.5 * velocity.mean_center_error_share, follow
    unit = UnitSettings(style=CommandStyle.POSITIONS_WITH_SPEEDS)
    for _, _, msg in read_bag(flir[1] / "bag", {"/ptz/joint_command"}):
        joints = JointCommand(list(msg.name), list(msg.position), list(msg.velocity))
        assert flir_ptu_contract_problem(joints, unit) is None, msg
