"""Offline linking and the finishing of ground truth, against boxes whose people are known."""

from __future__ import annotations

import numpy as np
import pytest

from tracker_ptz_sim.annotation import linking
from tracker_ptz_sim.annotation.linking import LinkConfig
from tracker_ptz_sim.simulation import ground_truth
from tracker_ptz_sim.simulation.ground_truth import Box, Detections, Tracks


def test_interpolation_fills_short_gaps_linearly_and_leaves_long_ones():
    boxes = {1: Box(0.0, 0.0, 10.0, 20.0), 5: Box(40.0, 8.0, 14.0, 20.0), 30: Box(0, 0, 5, 5)}
    filled = linking.interpolate(boxes, max_gap=3)
    assert sorted(filled) == [1, 2, 3, 4, 5, 30]  # the 24-frame gap stays open
    assert filled[3].x == pytest.approx(20.0) and filled[3].y == pytest.approx(4.0)
    assert filled[2].w == pytest.approx(11.0) and filled[4].w == pytest.approx(13.0)
    assert filled[2].score == 0.0  # interpolated, not observed


def walker(start: float, step: float, frames: range, y: float = 100.0) -> dict[int, Box]:
    return {f: Box(start + step * f, y, 20.0, 60.0, 0.8) for f in frames}


def test_two_people_crossing_with_misses_keep_their_ids():
    left = walker(0.0, 5.0, range(1, 61))
    right = walker(300.0, -5.0, range(1, 61), y=104.0)  # they pass each other at frame 30
    detections = Detections()
    for f in range(1, 61):
        boxes = []
        if f not in (28, 29, 30, 31):  # hidden behind the other while they cross
            boxes.append(left[f])
        boxes.append(right[f])
        if f in (40, 41, 42):  # weak boxes, only continue a track
            boxes[0] = Box(left[f].x, left[f].y, 20.0, 60.0, 0.2)
        if f == 10:
            boxes.append(Box(600.0, 400.0, 10.0, 10.0, 0.9))  # a lone false box
        detections.by_frame[f] = boxes
    tracks = linking.link(detections)
    assert len(tracks.ids()) == 2  # the lone box never makes min_boxes
    for ident, truth in zip(tracks.ids(), (left, right), strict=True):
        boxes = tracks.by_id[ident]
        assert all(abs(boxes[f].x - truth[f].x) < 1e-6 for f in boxes)
    left_track = next(b for b in tracks.by_id.values() if b[1].x < 100)
    assert 28 not in left_track and {27, 32, 40, 41, 42} <= set(left_track)


def test_a_track_ends_after_max_gap_frames_unseen():
    boxes = walker(0.0, 2.0, range(1, 11)) | walker(0.0, 2.0, range(40, 50))
    tracks = linking.link(Detections({f: [b] for f, b in boxes.items()}), LinkConfig(max_gap=15))
    assert [sorted(b)[0] for b in tracks.by_id.values()] == [1, 40]


def test_finish_clips_to_the_frame_and_measures_visibility():
    far = {1: Box(100.0, 100.0, 20.0, 40.0)}  # bottom at 140
    near = {1: Box(110.0, 110.0, 20.0, 40.0)}  # bottom at 150: in front, covers a quarter
    outside = {1: Box(-10.0, 0.0, 20.0, 40.0)}
    gt = linking.finish(Tracks({1: far, 2: near, 3: outside}), width=320, height=240)
    assert gt.by_id[1][1].visibility == pytest.approx(1 - (10 * 30) / (20 * 40))
    assert gt.by_id[2][1].visibility == 1.0
    assert gt.by_id[3][1].x == 0.0 and gt.by_id[3][1].w == 10.0


def test_ground_truth_round_trips_through_its_file(tmp_path):
    tracks = Tracks({3: {1: Box(1.5, 2.25, 30.0, 60.0, 1.0, 0.75)}})
    ground_truth.write_ground_truth(tracks, tmp_path / "gt.txt")
    assert (tmp_path / "gt.txt").read_text() == "1,3,1.50,2.25,30.00,60.00,1,1,0.750\n"
    back = ground_truth.read_tracks(tmp_path / "gt.txt")
    assert back.by_id[3][1].visibility == 0.75 and np.isclose(back.by_id[3][1].y, 2.25)
