"""Motion models and the alpha-beta(-gamma) gain rules against the seed's formulas and references."""

import itertools
import math

import numpy as np
import pytest
import scipy.linalg

from tracker_filter.filters import AlphaBetaFilter
from tracker_filter.gains import (
    GainRule,
    GhGains,
    is_stable,
    kalata_alpha,
    kalata_beta,
    resolve_gains,
    seed_stability_condition,
    startup_gains,
    tracking_index,
)
from tracker_filter.models import (
    CONSTANT_ACCELERATION,
    CONSTANT_VELOCITY,
    extrapolate_positions,
    model_for_layout,
)


def test_constant_velocity_matrices_are_the_seeds():
    dt, sigma = 1.1, 0.3
    A = np.array([[1, 0, dt, 0], [0, 1, 0, dt], [0, 0, 1, 0], [0, 0, 0, 1]])
    # seed 000 section 3, with the erratum "T should read T^2" applied
    Q = (
        np.array(
            [
                [dt**4 / 4, 0, dt**3 / 2, 0],
                [0, dt**4 / 4, 0, dt**3 / 2],
                [dt**3 / 2, 0, dt**2, 0],
                [0, dt**3 / 2, 0, dt**2],
            ]
        )
        * sigma**2
    )
    np.testing.assert_allclose(CONSTANT_VELOCITY.transition(dt), A)
    np.testing.assert_allclose(CONSTANT_VELOCITY.process_noise(dt, sigma), Q)
    np.testing.assert_array_equal(
        CONSTANT_VELOCITY.measurement_matrix, [[1, 0, 0, 0], [0, 1, 0, 0]]
    )
    assert CONSTANT_VELOCITY.state_layout == ("x", "y", "vx", "vy")


def test_constant_acceleration_matrices():
    dt, sigma = 0.5, 2.0
    F1 = np.array([[1, dt, dt * dt / 2], [0, 1, dt], [0, 0, 1]])
    G = np.array([dt**3 / 6, dt**2 / 2, dt])
    F = CONSTANT_ACCELERATION.transition(dt)
    Q = CONSTANT_ACCELERATION.process_noise(dt, sigma)
    assert CONSTANT_ACCELERATION.state_layout == ("x", "y", "vx", "vy", "ax", "ay")
    for axis in (0, 1):
        idx = [axis, axis + 2, axis + 4]
        np.testing.assert_allclose(F[np.ix_(idx, idx)], F1)
        np.testing.assert_allclose(Q[np.ix_(idx, idx)], np.outer(G, G) * sigma**2)
    np.testing.assert_allclose(Q[np.ix_([0, 2, 4], [1, 3, 5])], 0.0)


def test_extrapolation_follows_the_layout():
    mean = np.array([10.0, 20.0, 3.0, -4.0, 1.0, 2.0])
    np.testing.assert_allclose(
        extrapolate_positions(mean, CONSTANT_ACCELERATION.state_layout, 2.0), [[18.0, 16.0]]
    )
    np.testing.assert_allclose(
        extrapolate_positions(mean[:4], CONSTANT_VELOCITY.state_layout, 2.0), [[16.0, 12.0]]
    )
    with pytest.raises(ValueError, match="layout"):
        model_for_layout(("x", "y", "z"))


def steady_state_gains(model, sigma, measurement_noise, dt):
    """Per-axis steady-state Kalman gain (alpha, beta, gamma) from the discrete Riccati equation."""
    order = model.order
    idx = [0, 2, 4][: order + 1]
    F = model.transition(dt)[np.ix_(idx, idx)]
    Q = model.process_noise(dt, sigma)[np.ix_(idx, idx)]
    H = np.eye(1, order + 1)
    P = scipy.linalg.solve_discrete_are(F.T, H.T, Q, np.array([[measurement_noise**2]]))
    K = P @ H.T / (H @ P @ H.T + measurement_noise**2)
    return K[0, 0], K[1, 0] * dt, (K[2, 0] * dt * dt / 2 if order == 2 else None)


@pytest.mark.parametrize("sigma", [10.0, 100.0, 1000.0])
def test_kalata_rules_are_the_steady_state_kalman_gains(sigma):
    dt, noise = 0.12, 2.0
    alpha, beta, _ = steady_state_gains(CONSTANT_VELOCITY, sigma, noise, dt)
    assert kalata_beta(alpha) == pytest.approx(beta, rel=1e-9)
    assert kalata_alpha(tracking_index(sigma, noise, dt)) == pytest.approx(alpha, rel=1e-9)
    # the alpha-beta-gamma extension is close to (not exactly) the white-jerk steady state
    a3, b3, g3 = steady_state_gains(CONSTANT_ACCELERATION, sigma, noise, dt)
    gains = resolve_gains(a3, GainRule.KALATA, order=2)
    assert gains.beta == pytest.approx(b3, rel=0.01)
    assert gains.gamma == pytest.approx(g3, rel=0.03)


def test_seed_values_and_rule_formulas():
    assert kalata_beta(0.6) == pytest.approx(0.2702, abs=1e-4)  # seed code value
    assert kalata_beta(0.3) == pytest.approx(0.0534, abs=1e-4)  # seed section 6.2, Case 1
    for alpha in (0.1, 0.3, 0.6, 0.9):
        assert resolve_gains(alpha, "kalata").beta == pytest.approx(
            2 * (2 - alpha) - 4 * math.sqrt(1 - alpha)
        )
        assert resolve_gains(alpha, "benedict_bordner").beta == pytest.approx(
            alpha**2 / (2 - alpha)
        )
        assert resolve_gains(alpha, "critical_damping").beta == pytest.approx(
            2 - alpha - 2 * math.sqrt(1 - alpha)
        )
        g, h, k = resolve_gains(alpha, "critical_damping", order=2).as_tuple()
        theta = (1 - alpha) ** (1 / 3)
        assert (g, h, k) == pytest.approx(
            (1 - theta**3, 1.5 * (1 - theta**2) * (1 - theta), 0.5 * (1 - theta) ** 3)
        )


def test_seed_stability_condition_matches_the_closed_loop_spectral_radius():
    for alpha, beta in itertools.product(np.linspace(0.05, 2.2, 44), np.linspace(0.05, 4.5, 45)):
        assert seed_stability_condition(alpha, beta) == is_stable(GhGains(alpha, beta)), (
            alpha,
            beta,
        )


def test_invalid_gains_are_rejected_with_a_reason():
    with pytest.raises(ValueError, match="0 < alpha < 1"):
        resolve_gains(1.2, "kalata")
    with pytest.raises(ValueError, match="alpha-beta only"):
        resolve_gains(0.5, "benedict_bordner", order=2)
    with pytest.raises(ValueError, match="unstable"):
        resolve_gains(1.5, "free", beta=1.5)
    with pytest.raises(ValueError, match="needs beta"):
        resolve_gains(0.5, "free")
    with pytest.raises(ValueError, match="unstable"):
        resolve_gains(0.5, "free", order=2, beta=0.2, gamma=2.0)
    assert resolve_gains(0.5, "free", beta=0.2).as_tuple() == (0.5, 0.2)


@pytest.mark.parametrize("order", [1, 2])
def test_startup_gains_reproduce_the_least_squares_polynomial_fit(order):
    rng = np.random.default_rng(3)
    dt = 0.25
    times = np.arange(12) * dt
    z = np.column_stack([3.0 * times**2 - 5 * times, 40 * times]) + rng.normal(
        scale=2.0, size=(12, 2)
    )
    gains = resolve_gains(
        0.05, "kalata", order=order
    )  # tiny alpha: the schedule lasts the whole run
    P0 = np.eye(2 * (order + 1)) * 100.0
    f = AlphaBetaFilter(
        gains, np.concatenate([z[0], np.zeros(2 * order)]), P0, 0.0, 10.0, 2.0, startup=True
    )
    for n in range(1, 12):
        f.predict(times[n])
        f.update(z[n])
        if n < order:
            continue
        for axis in (0, 1):
            coeffs = np.polyfit(times[: n + 1], z[: n + 1, axis], order)
            derivatives = [np.polyval(np.polyder(coeffs, d), times[n]) for d in range(order + 1)]
            np.testing.assert_allclose(f.mean[axis::2], derivatives, rtol=1e-9, atol=1e-9)


def test_startup_hands_over_to_the_steady_gains():
    g, h, _ = startup_gains(1, 1)
    assert (g, h) == (1.0, 1.0)  # the second measurement gives the two-point velocity
    assert startup_gains(2, 2)[0] == 1.0
    assert startup_gains(1, 50)[0] < 0.1
