"""The Kalman filter on explicit matrices (F, G, Q, R): it is the built-in Kalman filter when given
the built-in model's matrices, and the default is seed 001's nominal filter."""

from __future__ import annotations

import numpy as np
import pytest

from tracker_filter.filter_registry import FILTERS
from tracker_filter.filters import FilterConfig, FilterKind, LinearModelFilterConfig
from tracker_filter.gated_hungarian.config import TrackerConfig
from tracker_filter.models import CONSTANT_VELOCITY, LinearModel, seed001_nominal_model

DT = 0.1


def test_given_the_constant_velocity_matrices_it_is_the_built_in_kalman_filter():
    sigma, noise = 50.0, 2.0
    model = LinearModel(
        CONSTANT_VELOCITY.transition(DT),
        np.eye(4),
        CONSTANT_VELOCITY.process_noise(DT, sigma),
        np.eye(2) * noise**2,
        CONSTANT_VELOCITY.state_layout,
    )
    explicit = LinearModelFilterConfig(model, initial_std=100.0)
    builtin = FilterConfig(FilterKind.KALMAN_CV, noise, sigma, initial_velocity_std=100.0)
    a, b = explicit.new_filter([10.0, 20.0], 0.0), builtin.new_filter([10.0, 20.0], 0.0)
    bank_a, bank_b = explicit.new_bank(), builtin.new_bank()
    bank_a.predict(0.0), bank_b.predict(0.0)
    bank_a.add(np.array([[10.0, 20.0]])), bank_b.add(np.array([[10.0, 20.0]]))
    rng = np.random.default_rng(1)
    for k in range(1, 20):
        z = np.array([10.0 + 30 * k * DT, 20.0]) + rng.normal(0, noise, 2)
        for f in (a, b):
            f.predict(k * DT)
            f.update(None if k % 5 == 0 else z)
        for bank in (bank_a, bank_b):
            bank.predict(k * DT)
            bank.update(np.array([], int) if k % 5 == 0 else np.array([0]), z[None])
        np.testing.assert_allclose(a.mean, b.mean, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(a.covariance, b.covariance, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(bank_a.means, bank_b.means, rtol=1e-9, atol=1e-9)


def test_the_default_explicit_model_is_seed_001s_nominal_filter():
    config = TrackerConfig.preset("multi", filter="kalman_linear_model")
    model = config.filter.model
    reference = seed001_nominal_model()
    assert model.state_layout == ("x", "y", "vx", "vy", "ax", "ay")
    np.testing.assert_array_equal(model.transition_matrix, reference.transition_matrix)
    assert model.transition_matrix[0, 2] == pytest.approx(1 / 20)
    assert model.transition_matrix[0, 4] == pytest.approx(0.5 / 400)
    np.testing.assert_array_equal(np.diag(model.process_covariance), [3, 3, 1, 1, 0.25, 0.25])
    np.testing.assert_array_equal(model.measurement_covariance, np.diag([3.0, 3.0]))
    assert "kalman_linear_model" in FILTERS


@pytest.mark.parametrize(
    ("overrides", "reason"),
    [
        ({"model_transition": [1.0, 0.0, 0.0]}, "square matrix"),
        ({"model_measurement_covariance": [1.0, 0.0, 0.0, -1.0]}, "semi-definite"),
        ({"model_state_layout": "vx vy x y"}, "start with x y"),
        ({"model_noise_gain": [1.0] * 5}, "6 rows"),
    ],
)
def test_bad_matrices_are_rejected_whatever_the_filter(overrides, reason):
    with pytest.raises(ValueError, match=reason):
        TrackerConfig.preset("multi", **overrides)
