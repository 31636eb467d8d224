"""The single-target filters: equal to direct NumPy implementations of seed 000's equations, the
common interface, bad input, and accuracy on synthetic trajectories."""

import numpy as np
import pytest

from tracker_filter.filters import (
    AlphaBetaFilter,
    FilterConfig,
    FilterKind,
    KalmanFilter,
    StateFilter,
)
from tracker_filter.gains import resolve_gains
from tracker_filter.gated_hungarian.config import (
    SEED_CYCLE,
    SEED_DT,
    SEED_SIGMA_A,
    TrackerConfig,
    seed_process_noise,
)
from tracker_filter.models import CONSTANT_ACCELERATION, CONSTANT_VELOCITY
from tracker_filter.synthetic import circle, piecewise_constant_velocity, seed_case1

SEED_A = np.array([[1, 0, SEED_DT, 0], [0, 1, 0, SEED_DT], [0, 0, 1, 0], [0, 0, 0, 1]], dtype=float)
SEED_Q = (
    np.array(
        [
            [SEED_DT**4 / 4, 0, SEED_DT**3 / 2, 0],
            [0, SEED_DT**4 / 4, 0, SEED_DT**3 / 2],
            [SEED_DT**3 / 2, 0, SEED_DT**2, 0],
            [0, SEED_DT**3 / 2, 0, SEED_DT**2],
        ]
    )
    * SEED_SIGMA_A**2
)
SEED_H = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])


def noisy_line_with_gaps(rng, count=40, gaps=(7, 8, 20, 21, 22)):
    z = np.column_stack([100 + 9.0 * np.arange(count), 50 + 2.0 * np.arange(count)]) + rng.normal(
        scale=1.0, size=(count, 2)
    )
    z[list(gaps)] = np.nan  # missed detections
    return z


def seed_kalman_reference(z, x0):
    """Seed 000's Kalman filter written out directly (section 3), misses as pure predictions."""
    x, P = x0.copy(), SEED_Q.copy()
    means, covariances = [], []
    for zk in z:
        x = SEED_A @ x
        P = SEED_A @ P @ SEED_A.T + SEED_Q
        if np.all(np.isfinite(zk)):
            K = P @ SEED_H.T @ np.linalg.inv(SEED_H @ P @ SEED_H.T + np.eye(2))
            x = x + K @ (zk - SEED_H @ x)
            P = (np.eye(4) - K @ SEED_H) @ P
        means.append(x)
        covariances.append(P)
    return np.array(means), np.array(covariances)


def run(f, times, z):
    means, covariances = [], []
    for t, zk in zip(times, z, strict=True):
        f.predict(t)
        f.update(zk if np.all(np.isfinite(zk)) else None)
        means.append(f.mean)
        covariances.append(f.covariance)
    return np.array(means), np.array(covariances)


def test_kalman_equals_the_seed_equations():
    z = noisy_line_with_gaps(np.random.default_rng(0))
    x0 = np.array([90.0, 50.0, 10.0, 0.0])  # seed: initial velocity = sweep velocity / 10
    f = KalmanFilter(CONSTANT_VELOCITY, x0, SEED_Q, 0.0, SEED_SIGMA_A, 1.0)
    means, covariances = run(f, SEED_DT * np.arange(1, len(z) + 1), z)
    ref_means, ref_covariances = seed_kalman_reference(z, x0)
    np.testing.assert_allclose(means, ref_means, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(covariances, ref_covariances, rtol=1e-8, atol=1e-12)


def test_seed_kalman_preset_in_seconds_gives_the_seed_positions():
    z = noisy_line_with_gaps(np.random.default_rng(1))
    config = TrackerConfig.preset("seed000_kalman").filter
    assert (
        config.process_noise
        == pytest.approx(seed_process_noise())
        == pytest.approx(25.2083, abs=1e-4)
    )
    f = config.new_filter(z[0], 0.0)
    means, _ = run(f, SEED_CYCLE * np.arange(1, len(z)), z[1:])
    ref_means, _ = seed_kalman_reference(z[1:], np.array([*z[0], 0.0, 0.0]))
    np.testing.assert_allclose(means[:, :2], ref_means[:, :2], atol=1e-8)
    np.testing.assert_allclose(
        means[:, 2:] * SEED_CYCLE, ref_means[:, 2:] * SEED_DT, atol=1e-8
    )  # px/frame


def test_constant_acceleration_kalman_equals_numpy_with_variable_dt():
    rng = np.random.default_rng(2)
    times = np.cumsum(rng.uniform(0.05, 0.3, size=30))
    z = np.column_stack([5 * times**2, -20 * times]) + rng.normal(scale=1.5, size=(30, 2))
    z[[4, 5, 17]] = np.nan
    sigma, R = 30.0, 1.5**2 * np.eye(2)
    x, P, t = np.zeros(6), np.eye(6) * 50.0, 0.0
    f = KalmanFilter(CONSTANT_ACCELERATION, x, P, 0.0, sigma, 1.5)
    H = CONSTANT_ACCELERATION.measurement_matrix
    for tk, zk in zip(times, z, strict=True):
        F, Q = (
            CONSTANT_ACCELERATION.transition(tk - t),
            CONSTANT_ACCELERATION.process_noise(tk - t, sigma),
        )
        x, P, t = F @ x, F @ P @ F.T + Q, tk
        if np.all(np.isfinite(zk)):
            K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
            x, P = x + K @ (zk - H @ x), (np.eye(6) - K @ H) @ P
        f.predict(tk)
        f.update(zk if np.all(np.isfinite(zk)) else None)
        np.testing.assert_allclose(f.mean, x, rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(f.covariance, P, rtol=1e-7, atol=1e-9)


@pytest.mark.parametrize("order", [1, 2])
def test_alpha_beta_equals_the_seed_equations(order):
    z = noisy_line_with_gaps(np.random.default_rng(4))
    gains = resolve_gains(0.6, "kalata", order=order)
    dt = 0.1  # the seed code's alpha-beta dt
    x0 = np.concatenate([z[0], [5.0, -1.0], [0.5, 0.0][: 2 * order - 2] or []])
    f = AlphaBetaFilter(gains, x0, np.eye(2 * order + 2), 0.0, 10.0, 1.0, startup=False)
    x, v, a = x0[:2].copy(), x0[2:4].copy(), (x0[4:6].copy() if order == 2 else np.zeros(2))
    for k, zk in enumerate(z[1:], start=1):
        # seed 000 section 3: predict, residual, correct; a miss coasts at constant velocity
        x_p, v_p = x + dt * v + 0.5 * a * dt * dt, v + a * dt
        if np.all(np.isfinite(zk)):
            r = zk - x_p
            x, v, a = (
                x_p + gains.alpha * r,
                v_p + gains.beta / dt * r,
                a + (2 * gains.gamma * r / dt**2 if order == 2 else 0),
            )
        else:
            x, v = x_p, v_p
        f.predict(k * dt)
        f.update(zk if np.all(np.isfinite(zk)) else None)
        np.testing.assert_allclose(
            f.mean, np.concatenate([x, v] + ([a] if order == 2 else [])), rtol=1e-12, atol=1e-9
        )


def test_a_miss_is_a_pure_prediction():
    for kind in FilterKind:
        f = FilterConfig(kind=kind).new_filter(np.array([10.0, 20.0]), 0.0)
        f.predict(0.1)
        f.update(np.array([11.0, 20.5]))
        f.predict(0.2)
        predicted_mean, predicted_cov = f.mean, f.covariance
        f.update(None)
        np.testing.assert_array_equal(f.mean, predicted_mean)
        np.testing.assert_array_equal(
            f.covariance, predicted_cov
        )  # not the seed's (I - KH)P on a miss
        f.predict(0.3)
        assert np.trace(f.covariance) > np.trace(predicted_cov)


@pytest.mark.parametrize("kind", list(FilterKind))
def test_interface_and_bad_input(kind):
    f = FilterConfig(kind=kind).new_filter(np.array([10.0, 20.0]), 1.0)
    assert isinstance(f, StateFilter)
    assert f.state_layout == kind.model.state_layout
    f.predict(1.1)
    f.update(np.array([12.0, 20.0]))
    before = (f.mean, f.covariance, f.time)
    for bad in (np.array([np.nan, 1.0]), np.array([np.inf, 0.0]), np.array([1.0, 2.0, 3.0])):
        with pytest.raises(ValueError, match="finite"):
            f.update(bad)
    for bad_time in (1.0, float("nan")):
        with pytest.raises(ValueError, match="cannot predict"):
            f.predict(bad_time)
    np.testing.assert_array_equal(f.mean, before[0])
    np.testing.assert_array_equal(f.covariance, before[1])
    assert f.time == before[2]
    z_pred, S = f.measurement_prediction()
    np.testing.assert_array_equal(z_pred, f.mean[:2])
    np.testing.assert_allclose(S, f.covariance[:2, :2] + 4.0 * np.eye(2))
    lead = 0.5
    expected = kind.model.transition(lead)[:2] @ f.mean
    np.testing.assert_allclose(f.predicted_position(lead), expected)
    np.testing.assert_allclose(f.predicted_position(0.0), f.mean[:2])


def filter_errors(config, trajectory, z):
    f = config.new_filter(z[0], trajectory.times[0])
    estimates = [f.mean[:2]]
    for t, zk in zip(trajectory.times[1:], z[1:], strict=True):
        f.predict(t)
        f.update(zk)
        estimates.append(f.mean[:2])
    return np.linalg.norm(np.array(estimates) - trajectory.positions, axis=1)


def rmse(errors):
    return float(np.sqrt(np.mean(errors**2)))


ALL_FILTERS = {
    "alpha_beta_0.3": FilterConfig(
        kind="alpha_beta", gains=resolve_gains(0.3, "kalata"), measurement_noise=3.0
    ),
    "alpha_beta_0.6": FilterConfig(
        kind="alpha_beta", gains=resolve_gains(0.6, "kalata"), measurement_noise=3.0
    ),
    "alpha_beta_gamma": FilterConfig(
        kind="alpha_beta_gamma", gains=resolve_gains(0.5, "kalata", order=2), measurement_noise=3.0
    ),
    "kalman_cv": FilterConfig(kind="kalman_cv", measurement_noise=3.0, process_noise=60.0),
    "kalman_ca": FilterConfig(kind="kalman_ca", measurement_noise=3.0, process_noise=50.0),
}


@pytest.mark.parametrize("name", list(ALL_FILTERS))
def test_straight_line_rmse_is_below_the_measurement_noise(name):
    sigma, rng = 3.0, np.random.default_rng(5)
    trajectory = piecewise_constant_velocity((50.0, 80.0), [(12.0, (40.0, -15.0))], dt=0.12)
    errors = filter_errors(ALL_FILTERS[name], trajectory, trajectory.measurements(sigma, rng))
    measurement_rmse = sigma * np.sqrt(2)  # per-point Euclidean error of the raw measurements
    assert rmse(errors[20:]) < 0.85 * measurement_rmse


def test_case1_turns_alpha_06_reacts_faster_but_is_noisier_than_alpha_03():
    # The filters are linear, so an estimate is the response to the true path (lag at the turns)
    # plus the response to the noise alone (estimate from noisy minus estimate from clean input).
    dt, leg, sigma = 0.12, 3.0, 1.5
    trajectory = seed_case1(dt=dt, leg=leg)
    turns = np.arange(1, 9) * round(leg / dt)
    after_turn = np.concatenate([np.arange(t, t + 10) for t in turns])
    lag, noise = {}, {}
    for name in ("alpha_beta_0.6", "alpha_beta_0.3"):
        clean = filter_errors(ALL_FILTERS[name], trajectory, trajectory.positions)
        lag[name] = clean[after_turn].mean()
        responses = []
        for seed in range(5):
            z = trajectory.measurements(sigma, np.random.default_rng(seed))
            f_noisy, f_clean = (
                ALL_FILTERS[name].new_filter(zz[0], 0.0) for zz in (z, trajectory.positions)
            )
            for t, zn, zc in zip(
                trajectory.times[1:], z[1:], trajectory.positions[1:], strict=True
            ):
                for f, zk in ((f_noisy, zn), (f_clean, zc)):
                    f.predict(t)
                    f.update(zk)
                responses.append(f_noisy.mean[:2] - f_clean.mean[:2])
        noise[name] = rmse(np.linalg.norm(responses, axis=1))
    # at the turns alpha 0.6 recovers faster (the seed's Case 1, 2nd simulation)...
    assert lag["alpha_beta_0.6"] < 0.5 * lag["alpha_beta_0.3"]
    # ...but passes more of the measurement noise through
    assert noise["alpha_beta_0.6"] > 1.3 * noise["alpha_beta_0.3"]
    assert noise["alpha_beta_0.6"] < sigma * np.sqrt(2)  # and still filters


@pytest.mark.parametrize("name", ["alpha_beta_0.6", "kalman_cv", "kalman_ca", "alpha_beta_gamma"])
def test_smooth_curve_is_filtered(name):
    sigma = 3.0
    trajectory = circle((320.0, 240.0), radius=100.0, period=8.0, duration=16.0, dt=0.12)
    errors = filter_errors(
        ALL_FILTERS[name], trajectory, trajectory.measurements(sigma, np.random.default_rng(7))
    )
    assert rmse(errors[20:]) < sigma * np.sqrt(2)


@pytest.mark.parametrize("name", list(ALL_FILTERS))
def test_stop_velocity_settles_to_zero(name):
    trajectory = piecewise_constant_velocity(
        (50.0, 80.0), [(4.0, (50.0, 20.0)), (6.0, (0.0, 0.0))], dt=0.12
    )
    z = trajectory.measurements(1.0, np.random.default_rng(8))
    config = ALL_FILTERS[name]
    f = config.new_filter(z[0], 0.0)
    for t, zk in zip(trajectory.times[1:], z[1:], strict=True):
        f.predict(t)
        f.update(zk)
    assert np.linalg.norm(f.mean[2:4]) < 10.0  # px/s, from 54 px/s before the stop
    assert np.linalg.norm(f.mean[:2] - trajectory.positions[-1]) < 3.0
