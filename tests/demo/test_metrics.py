"""Evaluation metrics against hand-computed ground truth."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tracker_msgs_py.geometry import Rect
from tracker_ptz_sim.evaluation.metrics import (
    clear_mot,
    every_object,
    follow_scores,
    hota,
    in_view,
    load_mot,
    visible_in_view,
    without_ignored,
)


def _two_walkers(frames: int = 10):
    return {
        f: {1: Rect(10 + 5 * f, 20, 10, 20), 2: Rect(200 - 5 * f, 80, 10, 20)}
        for f in range(1, frames + 1)
    }


def test_perfect_tracks_score_one():
    truth = _two_walkers()
    hypotheses = {f: {11: boxes[1], 12: boxes[2]} for f, boxes in truth.items()}
    scores = clear_mot(truth, hypotheses, list(truth))
    assert scores.mota == pytest.approx(1.0) and scores.idf1 == pytest.approx(1.0)
    assert scores.id_switches == 0 and scores.motp == pytest.approx(0.0)
    assert scores.frames == 10


def test_an_identity_swap_counts_two_switches():
    truth = _two_walkers()
    hypotheses = {
        f: ({11: b[1], 12: b[2]} if f <= 5 else {11: b[2], 12: b[1]}) for f, b in truth.items()
    }
    scores = clear_mot(truth, hypotheses, list(truth))
    assert scores.id_switches == 2
    assert scores.mota == pytest.approx(1.0 - 2 / 20)
    assert scores.idf1 == pytest.approx(0.5)


def test_misses_and_false_positives():
    truth = _two_walkers()
    hypotheses = {f: {11: b[1], 99: Rect(400, 400, 5, 5)} for f, b in truth.items()}
    scores = clear_mot(truth, hypotheses, list(truth))
    assert scores.recall == pytest.approx(0.5) and scores.precision == pytest.approx(0.5)
    assert scores.mota == pytest.approx(1.0 - (10 + 10) / 20)


def test_in_view_keeps_boxes_centred_in_the_window():
    truth = _two_walkers(2)
    windows = {1: Rect(0, 0, 100, 100), 2: Rect(150, 50, 100, 100)}
    visible = in_view(truth, windows)
    assert list(visible[1]) == [1] and list(visible[2]) == [2]


def test_visible_in_view_boxes_what_the_image_shows():
    """Person 1 (a 10x40 body with a 30 px stride at its feet) is cut at the window's bottom edge
    through the body: the in-view box is the body's visible slice, not the clipped stride-wide
    scene box. Person 2 shows a quarter of itself (a partial view, ignored); 3 is out of view."""
    label = np.zeros((120, 200), np.int64)
    label[10:50, 20:30] = 1  # body
    label[50:60, 10:40] = 1  # stride
    label[80:100, 100:110] = 2
    label[10:30, 160:170] = 3
    objects = {1: {1: Rect(10, 10, 30, 50), 2: Rect(100, 80, 10, 20), 3: Rect(160, 10, 10, 20)}}
    windows = {1: Rect(0, 0, 150, 45.2)}  # row 44 (centre 44.5) is the last inside: half of 1

    counted, partial = visible_in_view(lambda frame: label, objects, windows)

    assert counted == {1: {1: Rect(20, 10, 10, 35)}}
    assert in_view(objects, windows)[1][1] == Rect(10, 10, 30, 35.2)  # the stride-wide clip
    assert partial == {}  # person 2 is not in the window at all
    windows = {1: Rect(0, 0, 150, 85.0)}  # rows 80..84: a quarter of person 2
    counted, partial = visible_in_view(lambda frame: label, objects, windows)
    assert set(counted[1]) == {1} and partial == {1: {2: Rect(100, 80, 10, 5)}}
    windows = {1: Rect(0, 0, 150, 44.4)}  # row 44 (centre 44.5) is out: under half of 1
    counted, partial = visible_in_view(lambda frame: label, objects, windows)
    assert counted == {} and partial == {1: {1: Rect(20, 10, 10, 34)}}


def test_follow_scores():
    truth = _two_walkers()
    # The camera locks onto object 1 at frame 3 and keeps it 4 px off centre, loses it at frame 9.
    windows = {f: Rect.from_center(*truth[f][1].center, 60, 60) for f in truth}
    for f in windows:
        windows[f] = Rect(windows[f].x + 4, windows[f].y, 60, 60)
    windows[9] = windows[10] = Rect(300, 300, 60, 60)
    targets = {f: truth[f][1].center for f in range(3, 9)}
    scores = follow_scores(truth, windows, targets)
    assert scores.followed_id == 1 and scores.first_lock_frame == 3
    assert scores.frames_after_lock == 8
    assert scores.inside_share == pytest.approx(6 / 8)
    assert scores.mean_center_error_px == pytest.approx(4.0)
    assert scores.mean_center_error_share == pytest.approx(4.0 / 60)


def test_follow_scores_without_lock():
    scores = follow_scores(_two_walkers(), {1: Rect(0, 0, 10, 10)}, {})
    assert scores.followed_id is None and math.isnan(scores.mean_center_error_px)


def test_load_mot_reads_gt_and_tracker_files(tmp_path):
    gt = tmp_path / "gt.txt"
    gt.write_text("1,1,10,20,30,40,1,1,1\n1,2,0,0,5,5,0,1,1\n2,1,11,20,30,40,1,1,0.5\n")
    boxes = load_mot(gt)
    assert boxes == {1: {1: Rect(10, 20, 30, 40)}, 2: {1: Rect(11, 20, 30, 40)}}  # conf 0 = ignore
    tracks = tmp_path / "tracks.txt"
    tracks.write_text("3,7,1.5,2.5,3,4,1.000,-1,-1,-1\n")
    assert load_mot(tracks) == {3: {7: Rect(1.5, 2.5, 3, 4)}}
    bad = tmp_path / "bad.txt"
    bad.write_text("1,2,3\n")
    with pytest.raises(ValueError, match="bad.txt:1"):
        load_mot(bad)


def test_iou_distances_match_rect_iou():
    import numpy as np

    from tracker_ptz_sim.evaluation.metrics import iou_distances

    a = [Rect(0, 0, 10, 10), Rect(50, 50, 4, 4)]
    b = [Rect(5, 5, 10, 10), Rect(0, 0, 10, 10), Rect(100, 0, 1, 1)]
    d = iou_distances(
        np.array([[r.x, r.y, r.width, r.height] for r in a]),
        np.array([[r.x, r.y, r.width, r.height] for r in b]),
        max_distance=0.9,
    )
    assert d[0, 0] == pytest.approx(1 - a[0].iou(b[0])) and d[0, 1] == 0.0
    assert np.isnan(d[0, 2]) and np.isnan(d[1]).all()


def test_in_view_clips_boxes_to_the_window():
    truth = {1: {1: Rect(90, 10, 20, 20)}}  # centre (100, 20) on the window's right edge
    visible = in_view(truth, {1: Rect(0, 0, 101, 100)})
    assert visible[1][1] == Rect(90, 10, 11, 20)


def test_hota_perfect_swapped_and_missed():
    truth = _two_walkers()
    perfect = {f: {11: b[1], 12: b[2]} for f, b in truth.items()}
    assert hota(truth, perfect, list(truth)).hota == pytest.approx(1.0)
    # An identity swap halfway: detection stays perfect; each match shares 5 of its 15 frames of
    # ground truth or hypothesis with its partner: AssA = 5 / (5 + 5 + 5).
    swapped = {
        f: ({11: b[1], 12: b[2]} if f <= 5 else {11: b[2], 12: b[1]}) for f, b in truth.items()
    }
    scores = hota(truth, swapped, list(truth))
    assert scores.deta == pytest.approx(1.0) and scores.assa == pytest.approx(1 / 3)
    assert scores.hota == pytest.approx(math.sqrt(1 / 3))
    # One of two objects never found: DetA = 10 / (10 + 10), AssA = 1.
    half = {f: {11: b[1]} for f, b in truth.items()}
    scores = hota(truth, half, list(truth))
    assert scores.deta == pytest.approx(0.5) and scores.assa == pytest.approx(1.0)
    # Boxes shifted to IoU 1/3 count at thresholds up to 1/3 only: HOTA(0.5) is 0.
    shifted = {f: {11: Rect(b[1].x + 5, b[1].y, 10, 20)} for f, b in truth.items()}
    assert hota(truth, shifted, list(truth)).hota_50 == pytest.approx(0.0)


def test_hypotheses_on_ignored_objects_are_dropped():
    truth = {1: {1: Rect(0, 0, 10, 10)}}
    ignored = {1: {2: Rect(50, 50, 10, 10)}}
    hypotheses = {1: {7: Rect(0, 0, 10, 10), 8: Rect(51, 50, 10, 10), 9: Rect(200, 0, 5, 5)}}
    assert set(without_ignored(hypotheses, truth, ignored)[1]) == {7, 9}


def test_load_mot_splits_counted_and_ignored_rows(tmp_path):
    gt = tmp_path / "gt.txt"
    gt.write_text("1,1,0,0,10,10,1,1,1\n1,2,5,5,10,10,0,1,0.1\n")
    assert list(load_mot(gt)[1]) == [1]
    assert list(load_mot(gt, ignored=True)[1]) == [2]
    assert sorted(every_object(gt)[1]) == [1, 2]
