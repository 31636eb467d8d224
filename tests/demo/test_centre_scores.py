"""Seed 004's scores on box centres against hand-made runs: OSPA per cut-off, CLEAR MOT with a
centre-distance match, hidden (conf 0) movers ignored, occlusion gaps and missed occlusions."""

from __future__ import annotations

import math

import pytest

from tracker_msgs_py.geometry import Rect
from tracker_ptz_sim.evaluation.centre_scores import centre_scores, ospa_key
from tracker_ptz_sim.evaluation.metrics import Boxes

FRAMES = list(range(1, 21))


def box(x: float, y: float, side: float = 12.0) -> Rect:
    """A side x side box centred on (x, y)."""
    return Rect(x - side / 2, y - side / 2, side, side)


def two_movers() -> Boxes:
    """Mover 1 walks right along y 50, mover 2 stands at (200, 200), in every frame."""
    return {f: {1: box(20 + 2 * f, 50), 2: box(200, 200)} for f in FRAMES}


def test_tracks_on_every_mover_score_perfectly():
    truth = two_movers()
    scores = centre_scores(truth, {}, {f: {7: truth[f][1], 8: truth[f][2]} for f in FRAMES}, FRAMES)
    assert scores["mota"] == 1.0 and scores["idf1"] == 1.0 and scores["id_switches"] == 0
    assert scores["recall"] == 1.0 and scores["false_alarm_rate"] == 0.0
    assert scores[ospa_key(5.0)] == 0.0 and scores[ospa_key(10.0)] == 0.0
    assert scores["truth_per_frame"] == scores["estimates_per_frame"] == 2.0


def test_an_offset_within_the_cutoffs_is_its_distance_and_a_far_one_is_a_miss_and_a_false_alarm():
    truth = two_movers()
    near = {f: {7: box(*(c + 3.0 for c in truth[f][1].center)), 8: truth[f][2]} for f in FRAMES}
    scores = centre_scores(truth, {}, near, FRAMES)  # 3 px right and down: 4.24 px off
    off = math.hypot(3.0, 3.0)
    assert scores["mota"] == 1.0
    assert scores["motp_px"] == pytest.approx(math.sqrt(off**2 / 2))  # RMS over both matches
    assert scores[ospa_key(5.0)] == pytest.approx(math.sqrt(off**2 / 2))
    far = {f: {7: box(400, 400), 8: truth[f][2]} for f in FRAMES}
    scores = centre_scores(truth, {}, far, FRAMES)
    assert scores["recall"] == 0.5 and scores["false_alarm_rate"] == 0.5
    assert scores["mota"] == pytest.approx(0.0)  # a miss and a false alarm per 2 movers per frame
    assert scores[ospa_key(5.0)] == pytest.approx(5.0 / math.sqrt(2))  # one pair at the cut-off
    assert scores[ospa_key(10.0)] == pytest.approx(10.0 / math.sqrt(2))


def test_a_hidden_mover_is_neither_a_miss_nor_its_coasting_track_a_false_alarm():
    """Mover 1 is hidden (conf 0) in frames 8-12: the track that coasts on it there costs
    nothing, the same track after it keeps its identity; no track there costs nothing either."""
    truth = two_movers()
    hidden = {f: {1: truth[f].pop(1)} for f in range(8, 13)}
    coasting = {f: {7: hidden.get(f, truth[f])[1], 8: truth[f][2]} for f in FRAMES}
    scores = centre_scores(truth, hidden, coasting, FRAMES)
    assert scores["mota"] == 1.0 and scores["false_alarm_rate"] == 0.0
    assert scores[ospa_key(10.0)] == 0.0
    assert scores["occlusions"] == 1 and scores["missed_occlusion_rate"] == 0.0
    gone = {f: {i: b for i, b in coasting[f].items() if f not in hidden or i == 8} for f in FRAMES}
    assert centre_scores(truth, hidden, gone, FRAMES)["mota"] == 1.0
    # a track elsewhere while the mover is hidden is a false alarm
    elsewhere = {
        f: {**coasting[f], 9: box(500, 300)} if f in hidden else coasting[f] for f in FRAMES
    }
    assert centre_scores(truth, hidden, elsewhere, FRAMES)["false_alarm_rate"] > 0.0


def test_an_occlusion_is_missed_when_another_track_comes_out_of_it():
    truth = two_movers()
    hidden = {f: {1: truth[f].pop(1)} for f in range(8, 13)}
    relabelled = {
        f: {(7 if f < 8 else 17): hidden.get(f, truth[f])[1], 8: truth[f][2]} for f in FRAMES
    }
    scores = centre_scores(truth, hidden, relabelled, FRAMES)
    assert scores["occlusions"] == 1 and scores["missed_occlusions"] == 1
    assert scores["missed_occlusion_rate"] == 1.0
    assert scores["id_switches"] == 1 and scores["idf1"] < 1.0  # every mover found, renamed once
    assert scores["mota"] == pytest.approx(1.0 - 1 / 35)  # 35 counted mover-frames


def test_a_mover_that_leaves_hidden_makes_no_occlusion():
    truth = two_movers()
    hidden = {f: {1: truth[f].pop(1)} for f in range(15, 21)}  # hidden until the end
    tracks = {f: {7: hidden.get(f, truth[f])[1], 8: truth[f][2]} for f in FRAMES}
    scores = centre_scores(truth, hidden, tracks, FRAMES)
    assert scores["occlusions"] == 0 and math.isnan(scores["missed_occlusion_rate"])
