"""Zones through the whole graph (the demo runner, the motion graph): a walker standing in an
ignore zone is never followed; with a required zone the camera takes the walker only once their
feet have been in it, and then keeps them after they leave it."""

from __future__ import annotations

import pytest
from demo_runs import ONE_WALKER, run_demo

pytestmark = [pytest.mark.ros, pytest.mark.slow]

WALKER_PAN = -0.3  # rad: the unit starts pointed at the walker (as the standard-graph test)
# The walker's feet (bottom centre of its box) go from (411, 249) up-left to (230, 99) at frame
# 90, and back; they enter this rectangle at frame 13 (the camera's view, 168 px, would lose the
# walker within about 20 frames if it did not follow).
GATE = "0,0,400,0,400,228,0,228"
FEET_IN_GATE = 13


def _follow(tmp_path, *settings):
    from tracker_ptz_sim.evaluation import metrics, run_report
    from tracker_ptz_sim.evaluation.scoring import windows_and_targets
    from tracker_ptz_sim.simulation.scene_files import write_scene
    from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

    paths = write_scene(generate_scene(SceneConfig(**ONE_WALKER)), tmp_path / "scene")
    out = tmp_path / "run"
    run_demo(paths.video, out, f"ptz_camera.initial_pan={WALKER_PAN}", *settings)
    frames = run_report.collect(out / "bag")
    windows, targets = windows_and_targets(frames)
    locked = sum(1 for f in frames.values() if f.target is not None and f.target.locked)
    return metrics.follow_scores(metrics.load_mot(paths.gt), windows, targets), locked, frames


def _first_frame_in_gate(frames, track_id):
    """The first frame whose tracks hold `track_id` with its box's bottom centre in the gate."""
    for index, (_, frame) in enumerate(sorted(frames.items())):
        for track in frame.tracks.tracks if frame.tracks else []:
            foot = (track.bbox.x + track.bbox.width / 2, track.bbox.y + track.bbox.height)
            if track.id == track_id and foot[0] < 400 and foot[1] < 228:
                return index
    return None


def test_the_gate_decides_when_the_walker_is_followed(tmp_path):
    from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

    boxes = generate_scene(SceneConfig(**ONE_WALKER)).boxes
    feet_in = [b[0].x + b[0].width / 2 < 400 and b[0].y + b[0].height < 228 for b in boxes]
    assert feet_in.index(True) == FEET_IN_GATE  # the scene is what the constants say

    # the camera waits where it looks (no search sweep) until someone comes through the gate
    waiting = ("ptz_controller.search=none", f'tracker.required_zones="{GATE}"')
    follow, _, frames = _follow(tmp_path / "required", *waiting)
    assert follow.followed_id == 1, follow
    # not before its tracked feet were in the gate (here frame 11; the annotation's at 13; without
    # the zone the graph locks at frame 6), and then for good
    entered = _first_frame_in_gate(frames, follow.followed_id)
    assert entered is not None and entered > 6 and follow.first_lock_frame >= entered, follow
    assert follow.frames_after_lock >= 100 and follow.inside_share >= 0.95, follow

    everywhere = 'tracker.ignore_zones="0,0,640,0,640,480,0,480"'
    _, locked, frames = _follow(tmp_path / "ignored", everywhere)
    assert locked == 0
    assert not any(f.tracks and f.tracks.tracks for f in frames.values())  # nothing measured
