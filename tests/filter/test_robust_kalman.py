"""Seed 001's robust Kalman filter against independent transcriptions of the digest's equations."""

from __future__ import annotations

import numpy as np
import pytest

from tracker_filter.filter_registry import FILTERS
from tracker_filter.filters import LinearModelFilterConfig
from tracker_filter.gated_hungarian.config import TrackerConfig
from tracker_filter.models import seed001_nominal_model
from tracker_filter.robust_kalman import (
    EXACT_SEARCH_DECADES,
    LambdaRule,
    ModelUncertainty,
    RobustKalmanConfig,
    RobustKalmanFilter,
    RobustModel,
    exact_lambda,
    lambda_lower_bound,
    regularised_cost,
    seed001_uncertainty,
)

MODEL = seed001_nominal_model()
UNCERTAINTY = seed001_uncertainty()
F, Q, R = MODEL.transition_matrix, MODEL.process_covariance, MODEL.measurement_covariance
H = np.hstack([np.eye(2), np.zeros((2, 4))])
inv = np.linalg.inv


def circle_measurements(steps: int, seed: int = 3) -> np.ndarray:
    """A target on a 100 px circle at 20 fps with uniform integer noise in [-40, 40] px."""
    t = np.arange(steps) / 20.0
    rng = np.random.default_rng(seed)
    truth = np.stack([320 + 100 * np.cos(np.pi * t), 240 + 100 * np.sin(np.pi * t)], axis=1)
    return truth + rng.integers(-40, 41, size=truth.shape)


def run(f: RobustKalmanFilter, zs: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """(one-step prediction, filtered mean, lambda_hat) per measurement after the first."""
    out = []
    for i, z in enumerate(zs[1:], start=1):
        f.predict(i / 20.0)
        prediction = f.mean
        f.update(z)
        out.append((prediction, f.mean, f.lam))
    return out


def start(rule: LambdaRule, z0: np.ndarray, uncertainty: ModelUncertainty = UNCERTAINTY):
    config = RobustKalmanConfig(MODEL, uncertainty, rule, initial_std=np.sqrt(1e3))
    f = config.new_filter(z0, 0.0)
    assert isinstance(f, RobustKalmanFilter)
    return f


def nominal_filtered_form(zs: np.ndarray) -> list[np.ndarray]:
    """The digest's section 2, transcribed: Step 0 with Pi0 = 1e3 I, then the filtered form."""
    p = inv(inv(1e3 * np.eye(6)) + H.T @ inv(R) @ H)
    x = p @ H.T @ inv(R) @ zs[0]
    means = []
    for z in zs[1:]:
        p = inv(inv(Q + F @ p @ F.T) + H.T @ inv(R) @ H)
        x = F @ x + p @ H.T @ inv(R) @ (z - H @ F @ x)
        means.append(x)
    return means


def theorem_3_4_step(x, p, z, lam, unc: ModelUncertainty = UNCERTAINTY):
    """One step of Theorem 3.4 written as printed (3.38, 3.39, 3.41, 3.42, 3.43 without the
    erratum's inverse, 3.44-3.49), with explicit inverses. P_hat is taken in its form 3.41: the
    exact rule can pick lambda_hat ~ 1e6 lambda_l, where 3.40's inverse of an inverse loses digits
    (test_the_two_forms_of_p_hat_agree checks 3.40 = 3.41 where both are well conditioned)."""
    e_f, e_g, m = unc.E_f, unc.E_g, unc.M
    q_hat = inv(inv(Q) + lam * e_g.T @ inv(np.eye(1) + lam * e_f @ p @ e_f.T) @ e_g)
    r_hat = R - (1 / lam) * H @ m @ m.T @ H.T
    p_hat = p - p @ e_f.T @ inv(np.eye(1) / lam + e_f @ p @ e_f.T) @ e_f @ p
    g_hat = np.eye(6) - lam * F @ p_hat @ e_f.T @ e_g
    f_hat = (F - lam * g_hat @ q_hat @ e_g.T @ e_f) @ (np.eye(6) - lam * p_hat @ e_f.T @ e_f)
    x_pred = f_hat @ x
    p_pred = F @ p_hat @ F.T + g_hat @ q_hat @ g_hat.T
    r_e = r_hat + H @ p_pred @ H.T
    p_new = p_pred - p_pred @ H.T @ inv(r_e) @ H @ p_pred
    return x_pred, x_pred + p_new @ H.T @ inv(r_hat) @ (z - H @ x_pred), p_new


def g_transcribed(lam, x_filtered, p_filtered, z, unc: ModelUncertainty = UNCERTAINTY) -> float:
    """G(lambda), eqs. 3.21-3.24 with the digest's identifications, as printed (12 x 12 solve)."""
    weight = np.zeros((12, 12))
    weight[:6, :6], weight[6:, 6:] = inv(p_filtered), inv(Q)
    w, a = inv(R), H @ np.hstack([F, np.eye(6)])
    b = z - H @ F @ x_filtered
    h_bar, e_a, e_b = H @ unc.M, np.hstack([unc.E_f, unc.E_g]), -unc.E_f @ x_filtered
    k = unc.M.shape[1]
    w_lam = w + w @ h_bar @ np.linalg.pinv(lam * np.eye(k) - h_bar.T @ w @ h_bar) @ h_bar.T @ w
    q_lam = weight + lam * e_a.T @ e_a
    x = inv(q_lam + a.T @ w_lam @ a) @ (a.T @ w_lam @ b + lam * e_a.T @ e_b)
    r = a @ x - b
    return float(x @ weight @ x + lam * np.sum((e_a @ x - e_b) ** 2) + r @ w_lam @ r)


def transcription_tolerance(lam: float) -> float:
    """The printed equations lose digits as lambda_hat grows (lambda P_hat E_f^T is a small
    difference times a large number); the exact rule goes up to 1e4 lambda_l."""
    return max(1e-9, 1e-10 * lam / lambda_lower_bound(MODEL, UNCERTAINTY))


def test_lower_bound_is_the_digests_value():
    assert lambda_lower_bound(MODEL, UNCERTAINTY) == pytest.approx(0.08 / 3, rel=1e-12)


def test_nominal_rule_is_the_filtered_form_to_1e9():
    zs = circle_measurements(120)
    got = [mean for _, mean, _ in run(start(LambdaRule.NOMINAL, zs[0]), zs)]
    np.testing.assert_allclose(got, nominal_filtered_form(zs), rtol=0, atol=1e-9)


@pytest.mark.parametrize("rule", [LambdaRule.CHEAP, LambdaRule.EXACT])
def test_with_m_zero_the_robust_filter_is_the_nominal_one(rule):
    zs = circle_measurements(80)
    no_uncertainty = ModelUncertainty(np.zeros((6, 1)), UNCERTAINTY.E_f, UNCERTAINTY.E_g)
    got = [mean for _, mean, _ in run(start(rule, zs[0], no_uncertainty), zs)]
    np.testing.assert_allclose(got, nominal_filtered_form(zs), rtol=0, atol=1e-9)


def test_nominal_rule_equals_the_kalman_linear_model_filter():
    zs = circle_measurements(60)
    robust = start(LambdaRule.NOMINAL, zs[0])
    reference = LinearModelFilterConfig(MODEL).new_filter(zs[0], 0.0)
    reference._kf.x, reference._kf.P = robust.mean, robust.covariance  # the same start
    for i, z in enumerate(zs[1:], start=1):
        for f in (robust, reference):
            f.predict(i / 20.0)
            f.update(z)
        np.testing.assert_allclose(robust.mean, reference.mean, rtol=1e-9, atol=1e-7)


@pytest.mark.parametrize("rule", [LambdaRule.CHEAP, LambdaRule.EXACT])
def test_each_step_matches_theorem_3_4_transcribed(rule):
    zs = circle_measurements(60)
    f = start(rule, zs[0])
    for i, z in enumerate(zs[1:], start=1):
        x, p = f.mean, f.covariance
        f.predict(i / 20.0)
        f.update(z)
        _, x, p = theorem_3_4_step(x, p, z, f.lam)
        rtol = transcription_tolerance(f.lam)
        np.testing.assert_allclose(f.mean, x, rtol=rtol, atol=1e-9)
        np.testing.assert_allclose(f.covariance, p, rtol=rtol, atol=1e-9)


def test_the_two_forms_of_p_hat_agree():
    f = start(LambdaRule.CHEAP, circle_measurements(1)[0])
    run(f, circle_measurements(20))
    p, e_f = f.covariance, UNCERTAINTY.E_f
    for lam in (0.03, 1.0, 30.0):
        form_3_40 = inv(inv(p) + lam * e_f.T @ e_f)
        form_3_41 = p - p @ e_f.T @ inv(np.eye(1) / lam + e_f @ p @ e_f.T) @ e_f @ p
        np.testing.assert_allclose(form_3_40, form_3_41, rtol=1e-7, atol=1e-9)


def test_cheap_rule_uses_one_and_a_half_times_the_lower_bound():
    zs = circle_measurements(5)
    lams = [lam for _, _, lam in run(start(LambdaRule.CHEAP, zs[0]), zs)]
    assert lams == pytest.approx([1.5 * 0.08 / 3] * 4, rel=1e-12)


#: a rank-two uncertainty (k = 2): position and velocity perturbed apart, so that G has more
#: than one pole and the exact rule searches a grid instead of solving for the turning point
RANK_TWO = ModelUncertainty(
    M=np.array([[0.2, 0.0], [0.2, 0.1], [0.1, 0.0], [0.1, 0.1], [0.1, 0.0], [0.1, 0.0]]),
    E_f=np.array([[0.0, 0.0, 1.0, 1.0, 1.0, 1.0], [0.0, 0.0, 1.0, -1.0, 0.0, 0.0]]),
    E_g=np.array([[1.0, 1.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0, 0.0, 0.0]]),
)


@pytest.mark.parametrize("unc", [UNCERTAINTY, RANK_TWO], ids=["rank one", "rank two"])
def test_exact_rule_lambda_is_a_minimum_of_g(unc: ModelUncertainty):
    zs = circle_measurements(40)
    f = start(LambdaRule.EXACT, zs[0], unc)
    lower = lambda_lower_bound(MODEL, unc)
    interior = 0
    for i, z in enumerate(zs[1:], start=1):
        x, p = f.mean, f.covariance
        f.predict(i / 20.0)
        lam = exact_lambda(MODEL, unc, x, p, z, lower)
        cost = g_transcribed(lam, x, p, z, unc)
        for other in (lam, lower * 1.01, lower * 30):
            fast = regularised_cost(other, MODEL, unc, x, p, z)
            assert fast == pytest.approx(g_transcribed(other, x, p, z, unc), rel=1e-9)
        s = np.log10(lam / lower - 1.0)
        lo, hi = EXACT_SEARCH_DECADES
        for side, end in ((-1, lo), (1, hi)):
            beside = lower * (1.0 + 10.0 ** (s + side * np.array([0.05, 0.3, 1.0])))
            costs = [g_transcribed(b, x, p, z, unc) for b in beside]
            if abs(s - end) < 1e-6:  # G still falls at the search's end (see EXACT_SEARCH_DECADES)
                continue
            assert min(costs) > cost
        interior += lo + 1e-6 < s < hi - 1e-6
        f.update(z)
        assert f.lam == pytest.approx(lam, rel=1e-12)
    assert interior >= 5


def test_rank_one_lambda_is_no_worse_than_a_fine_search():
    """Seed 001's uncertainty has rank one: lambda_hat is G's turning point in closed form, at
    least as low as the best of 20001 values over the whole search range."""
    zs = circle_measurements(60, seed=5)
    f = start(LambdaRule.EXACT, zs[0])
    lower = lambda_lower_bound(MODEL, UNCERTAINTY)
    lams = lower * (1.0 + 10.0 ** np.linspace(*EXACT_SEARCH_DECADES, 20001))
    robust = RobustModel(MODEL, UNCERTAINTY)
    for i, z in enumerate(zs[1:], start=1):
        x, p = f.mean, f.covariance
        f.predict(i / 20.0)
        f.update(z)
        terms = robust.cost_terms(x, p, z)
        best = float(terms.costs(lams).min())
        found = terms.cost(f.lam)
        assert found == pytest.approx(g_transcribed(f.lam, x, p, z), rel=1e-9)
        assert found <= best * (1.0 + 1e-12)


def test_exact_rule_predicts_with_the_previous_steps_lambda():
    zs = circle_measurements(10)
    f = start(LambdaRule.EXACT, zs[0])
    for i, z in enumerate(zs[1:], start=1):
        x, p, previous = f.mean, f.covariance, f.lam
        f.predict(i / 20.0)
        expected = theorem_3_4_step(x, p, z, previous)[0]
        np.testing.assert_allclose(
            f.mean, expected, rtol=transcription_tolerance(previous), atol=1e-9
        )
        f.update(z)


def test_a_miss_keeps_the_prediction_and_a_bad_measurement_changes_nothing():
    zs = circle_measurements(10)
    f = start(LambdaRule.CHEAP, zs[0])
    run(f, zs[:5])
    f.predict(5 / 20.0)
    predicted, predicted_cov = f.mean, f.covariance
    with pytest.raises(ValueError):
        f.update(np.array([np.nan, 1.0]))
    np.testing.assert_array_equal(f.mean, predicted)
    f.update(None)
    np.testing.assert_array_equal(f.mean, predicted)
    np.testing.assert_array_equal(f.covariance, predicted_cov)
    f.predict(6 / 20.0)
    f.predict(7 / 20.0)  # a second predict commits the first as a miss
    assert f.time == 7 / 20.0
    with pytest.raises(ValueError):
        f.predict(6 / 20.0)


def test_registered_and_built_from_the_trackers_parameters():
    assert "robust_kalman" in FILTERS
    config = TrackerConfig.preset("multi", filter="robust_kalman", robust_lambda_rule="cheap")
    factory = config.filter
    assert isinstance(factory, RobustKalmanConfig)
    assert factory.rule is LambdaRule.CHEAP
    with pytest.raises(ValueError, match="robust_m"):
        TrackerConfig.preset("multi", filter="robust_kalman", robust_m=[0.1, 0.2])


@pytest.mark.parametrize("rule", [LambdaRule.NOMINAL, LambdaRule.EXACT])
def test_stamps_step_equals_the_per_frame_model_at_20_fps(rule):
    zs = circle_measurements(40)
    per_frame = start(rule, zs[0])
    config = RobustKalmanConfig(
        MODEL, UNCERTAINTY, rule, initial_std=np.sqrt(1e3), from_stamps=True
    )
    stamped = config.new_filter(zs[0], 0.0)
    for i, z in enumerate(zs[1:], start=1):
        for f in (per_frame, stamped):
            f.predict(i / 20.0)
            f.update(z)
        np.testing.assert_allclose(stamped.mean, per_frame.mean, rtol=1e-12, atol=1e-9)


def test_stamps_step_keeps_velocities_in_px_per_second_at_any_frame_rate():
    """A target walking 60 px/s filmed at 10 fps: with the stamps' interval the velocity is
    60 px/s; one step of the T = 1/20 s matrices per frame reads it as 120 px/s. (The nominal
    rule: the robust filter's velocity shrinks by design, E_f weighing vx + vy + ax + ay.)"""
    fps, speed = 10.0, 60.0
    zs = np.stack([100 + speed * np.arange(80) / fps, np.full(80, 200.0)], axis=1)
    estimates = {}
    for from_stamps in (False, True):
        config = RobustKalmanConfig(MODEL, UNCERTAINTY, LambdaRule.NOMINAL, from_stamps=from_stamps)
        f = config.new_filter(zs[0], 0.0)
        for i, z in enumerate(zs[1:], start=1):
            f.predict(i / fps)
            f.update(z)
        estimates[from_stamps] = f.mean[2]
    assert estimates[True] == pytest.approx(speed, rel=0.05)
    assert estimates[False] == pytest.approx(speed * 20.0 / fps, rel=0.05)


def test_stamps_step_needs_a_kinematic_state():
    from tracker_filter.models import LinearModel

    odd = LinearModel(np.eye(3), np.eye(3), np.eye(3), np.eye(2), ("x", "y", "w"))
    three = ModelUncertainty(np.zeros((3, 1)), np.zeros((1, 3)), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="kinematic"):
        RobustKalmanConfig(odd, three, LambdaRule.CHEAP, from_stamps=True)
