"""Seed 001's prediction experiment: the protocol's pieces behave as stated."""

from __future__ import annotations

import numpy as np
import pytest

from tracker_ptz_sim.evaluation import prediction_study as study


@pytest.mark.parametrize("name", list(study.PROTOCOLS))
def test_each_protocol_is_a_smooth_hand_path_in_the_image(name):
    path = study.PROTOCOLS[name].trajectory(np.random.default_rng(1))
    assert path.shape == (study.FRAMES, 2)
    assert np.all((path > 0) & (path < [640, 480]))
    steps = np.linalg.norm(np.diff(path, axis=0), axis=1)
    assert steps.max() < 40  # px per frame at 20 fps: a hand, not a jump


def test_vibration_is_the_theses_integer_noise():
    truth = np.zeros((20000, 2))
    noise = study.vibrate(truth, np.random.default_rng(2))
    assert noise.min() == -40 and noise.max() == 40
    assert np.all(noise == np.round(noise))
    assert noise.std() == pytest.approx(np.sqrt((81**2 - 1) / 12), rel=0.02)  # ~23.4 px


def test_without_noise_a_straight_walk_is_predicted_within_a_pixel_after_the_start():
    t = np.arange(60) / study.FPS
    line = np.stack([100 + 40 * t, 200 - 20 * t], axis=1)  # 2.2 px per frame
    for factory in study.predictors().values():
        predicted = study.one_step_predictions(factory, line)  # of frames 1..59
        assert np.linalg.norm(predicted[-20:] - line[1:][-20:], axis=1).max() < 1.0


def test_runs_are_reproducible_and_robust_beats_nominal_on_the_thesis_protocol():
    protocol = study.Protocol(study.concentric_circles)
    first = study.run_protocol("circles", protocol, runs=8, seed=5)
    again = study.run_protocol("circles", protocol, runs=8, seed=5)
    for name in first.scored_noisy:
        np.testing.assert_array_equal(first.scored_noisy[name], again.scored_noisy[name])
    nominal = first.scored_noisy["nominal"].mean()
    assert 0.9 * study.THESIS_PX["nominal"] <= nominal <= 1.1 * study.THESIS_PX["nominal"]
    comparison = first.comparison("robust exact", "noisy")
    assert comparison.mean < 0 and comparison.robust_better >= 6


def test_camshift_follows_the_rendered_ball_within_a_few_pixels():
    rng = np.random.default_rng(4)
    truth = study.concentric_circles(rng)
    measured = study.camshift_centres(truth, rng)
    error = np.linalg.norm(measured - truth, axis=1)
    assert np.median(error) < 2.0 and error.max() < 0.5 * study.BALL_RADIUS
