"""Single-target scores (Q1 mean IoU, Q2 centre in the 0.8 x shorter-side square, success share)."""

from __future__ import annotations

import numpy as np
import pytest

from tracker_filter.colour_particle import HistogramAppearance, ParticleFilterConfig
from tracker_msgs_py.geometry import Rect
from tracker_ptz_sim.evaluation.single_target import (
    SingleTargetScores,
    centre_inside,
    follow_particles,
    pooled,
    score_single_target,
)


def test_a_perfect_estimate_scores_one_everywhere():
    truth = {k: Rect(10.0 + k, 20.0, 40.0, 80.0) for k in range(5)}
    scores = score_single_target(truth, dict(truth))
    assert scores == SingleTargetScores(5, 1.0, 1.0, 1.0, 0)


def test_q2_square_is_0_8_of_the_shorter_side_centred_on_the_truth():
    truth = Rect.from_center(100.0, 100.0, 40.0, 80.0)  # square half-side = 0.8 * 40 / 2 = 16
    assert centre_inside(Rect.from_center(116.0, 84.0, 10.0, 10.0), truth)
    assert not centre_inside(Rect.from_center(116.5, 100.0, 10.0, 10.0), truth)
    assert not centre_inside(Rect.from_center(100.0, 117.0, 10.0, 10.0), truth)


def test_misses_score_zero_iou_and_count_as_missed():
    truth = {0: Rect(0, 0, 10, 10), 1: Rect(0, 0, 10, 10), 2: Rect(0, 0, 10, 10)}
    estimates = {0: Rect(0, 0, 10, 10), 1: None}  # frame 2 absent
    scores = score_single_target(truth, estimates)
    assert scores.frames == 3 and scores.missed == 2
    assert scores.mean_iou == pytest.approx(1 / 3)
    assert scores.centre_in_box == pytest.approx(1 / 3)
    assert scores.success == pytest.approx(1 / 3)


def test_estimates_outside_the_truth_frames_are_ignored():
    truth = {3: Rect(0, 0, 10, 10)}
    scores = score_single_target(truth, {3: Rect(5, 0, 10, 10), 4: Rect(0, 0, 10, 10)})
    assert scores.frames == 1
    assert scores.mean_iou == pytest.approx(50 / 150)
    assert scores.success == 0.0
    assert scores.centre_in_box == 0.0  # centre 5 px off; the square's half-side is 0.8*10/2 = 4


def test_pooled_weights_runs_by_their_frames():
    a = SingleTargetScores(10, 1.0, 1.0, 1.0, 0)
    b = SingleTargetScores(30, 0.0, 0.0, 0.0, 30)
    total = pooled([a, b])
    assert total == SingleTargetScores(40, 0.25, 0.25, 0.25, 30)
    assert pooled([]) == SingleTargetScores(0, 0.0, 0.0, 0.0, 0)


def test_particle_filter_follows_a_coloured_box_and_replays_identically():
    rng = np.random.default_rng(0)
    background = rng.integers(60, 160, size=(120, 200, 3), dtype=np.uint8)
    truth, frames = {}, []
    for k in range(40):
        image = background.copy()
        x = 40 + k
        image[30:90, x : x + 24] = (30, 30, 200)
        frames.append(image)
        truth[k] = Rect(float(x), 30.0, 24.0, 60.0)

    def run() -> dict:
        config = ParticleFilterConfig(particles=200)
        return follow_particles(frames, 0, truth[0], 39, HistogramAppearance(), config, seed=3)

    boxes = run()
    assert sorted(boxes) == list(range(1, 40))
    # the filter starts at rest and needs some frames to take up the box's speed
    scores = score_single_target({k: b for k, b in truth.items() if k >= 20}, boxes)
    assert scores.mean_iou > 0.6 and scores.missed == 0
    assert run() == boxes
