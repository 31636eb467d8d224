"""Run scores against hand-made runs: the pan-tilt figures and the whole evaluation."""

from __future__ import annotations

import json
import math

import pytest

from tracker_msgs_py.geometry import Rect
from tracker_ptz_sim.evaluation.run_files import write_evaluation
from tracker_ptz_sim.evaluation.scoring import RunTrace, pan_tilt_scores

FPS = 10.0


def _walkers(frames: int):
    """Object 1 walks right from frame 1 on; object 2 stands at x 300 from frame 1 to `frames`."""
    return {
        f: {1: Rect(10 + 2 * f, 100, 20, 40), 2: Rect(300, 100, 20, 40)}
        for f in range(1, frames + 1)
    }


def _trace(frames: int, targets: dict[int, tuple[float, float]]) -> RunTrace:
    trace = RunTrace(FPS)
    for f in range(1, frames + 1):
        trace.windows[f] = Rect(0, 0, 400, 400)
        trace.pan_tilt[f] = (0.0, 0.0)
    trace.targets = targets
    trace.target_ids = dict.fromkeys(targets, 5)
    return trace


def test_target_on_one_object_all_along():
    truth = _walkers(50)
    targets = {f: truth[f][1].center for f in range(11, 51)}
    scores = pan_tilt_scores(truth, _trace(50, targets))
    assert scores.locked_share == pytest.approx(40 / 50)
    assert scores.on_object_share == 1.0
    assert scores.followed_changes == 0 and scores.reacquire_s == []
    assert scores.first_lock_s == pytest.approx(1.0)  # objects from frame 1, lock at frame 11
    errors = [math.hypot(truth[f][1].center[0] - 200, 120 - 200) for f in range(11, 51)]
    assert scores.mean_center_error_px == pytest.approx(sum(errors) / 40)


def test_target_on_nothing_and_unexplained_switch():
    truth = _walkers(40)
    targets = {f: truth[f][1].center for f in range(1, 11)}
    targets |= {f: (390.0, 390.0) for f in range(11, 16)}  # on no object for 0.5 s
    targets |= {f: truth[f][2].center for f in range(16, 41)}  # then object 2: 1 is still there
    scores = pan_tilt_scores(truth, _trace(40, targets))
    assert scores.on_object_share == pytest.approx(35 / 40)
    assert scores.followed_changes == 1 and scores.unexplained_changes == 1
    assert scores.reacquire_s == [pytest.approx(0.5)]


def test_switch_after_the_object_left_is_explained():
    truth = _walkers(40)
    for f in range(21, 41):
        del truth[f][1]  # object 1 leaves after frame 20
    targets = {f: truth[f][1].center for f in range(1, 21)}
    targets |= {f: truth[f][2].center for f in range(21, 41)}
    scores = pan_tilt_scores(truth, _trace(40, targets))
    assert scores.followed_changes == 1 and scores.unexplained_changes == 0


def test_switch_after_the_object_went_out_of_the_counted_ones_is_explained():
    """A person walking out at the scene's edge keeps a sliver of a box (conf 0, under the
    visibility threshold) for a few frames: they have left, and moving on is explained. The same
    switch while they are still counted is not."""
    truth = _walkers(40)
    targets = {f: truth[f][1].center for f in range(1, 21)}
    targets |= {f: truth[f][2].center for f in range(21, 41)}
    counted = {f: dict(boxes) for f, boxes in truth.items()}
    for f in range(21, 41):
        del counted[f][1]  # object 1's rows from frame 21 on are ignored (a sliver at the edge)
    left = pan_tilt_scores(truth, _trace(40, targets), counted)
    assert left.followed_changes == 1 and left.unexplained_changes == 0
    stayed = pan_tilt_scores(truth, _trace(40, targets))
    assert stayed.followed_changes == 1 and stayed.unexplained_changes == 1


def test_switch_as_the_object_walks_out_is_explained():
    """A person walking out at the scene's edge is counted down to a quarter of them in it: moving
    on a frame before that last sliver goes is following them out, not changing whom the camera
    follows. Gone only for a moment (hidden, back within 2 s), or leaving only a second later,
    they were still there."""

    def switch_at_21(gone: range):
        truth = _walkers(60)
        for f in gone:
            del truth[f][1]
        targets = {f: truth[f][1].center for f in range(1, 21)}
        targets |= {f: truth[f][2].center for f in range(21, 61)}
        return pan_tilt_scores(truth, _trace(60, targets))

    left_next_frame = switch_at_21(range(22, 61))
    assert left_next_frame.followed_changes == 1 and left_next_frame.unexplained_changes == 0
    hidden_for_a_moment = switch_at_21(range(22, 30))
    assert hidden_for_a_moment.unexplained_changes == 1
    left_a_second_later = switch_at_21(range(31, 61))
    assert left_a_second_later.unexplained_changes == 1


def test_write_evaluation_writes_scores_tracks_and_plots(tmp_path):
    truth = _walkers(20)
    gt = tmp_path / "gt.txt"
    gt.write_text(
        "".join(
            f"{f},{i},{b.x},{b.y},{b.width},{b.height},1,1,1\n"
            for f, boxes in truth.items()
            for i, b in boxes.items()
        )
    )
    trace = _trace(20, {f: truth[f][1].center for f in range(1, 21)})
    trace.hypotheses = {f: {7: truth[f][1], 8: truth[f][2]} for f in truth}
    result = write_evaluation(trace, gt, tmp_path / "out")
    assert result["whole_scene"]["mota"] == pytest.approx(1.0)
    assert result["in_view"]["hota"] == pytest.approx(1.0)
    saved = json.loads((tmp_path / "out" / "evaluation.json").read_text())
    assert saved["pan_tilt"]["on_object_share"] == 1.0
    assert len((tmp_path / "out" / "tracks.txt").read_text().splitlines()) == 40
    assert (tmp_path / "out" / "plots.png").read_bytes()[:4] == b"\x89PNG"


def test_a_target_on_a_pair_keeps_following_the_same_person():
    """Two people side by side, boxes overlapping: a target between their centres is on both,
    and the nearer centre flips with every stride. That is one followed person, not a change per
    flip; moving off the first one's box onto the other's alone is a change."""
    truth = {f: {1: Rect(100, 100, 30, 60), 2: Rect(120, 100, 30, 60)} for f in range(1, 41)}
    # Between the centres (115 and 135), alternately nearer one and the other, inside both boxes.
    targets = {f: (123.0 if f % 2 else 127.0, 130.0) for f in range(1, 31)}
    targets |= {f: (145.0, 130.0) for f in range(31, 41)}  # on person 2's box only
    scores = pan_tilt_scores(truth, _trace(40, targets))
    assert scores.on_object_share == 1.0
    assert scores.followed_changes == 1 and scores.unexplained_changes == 1
