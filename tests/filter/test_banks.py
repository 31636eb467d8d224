"""The vectorised filter bank performs exactly the single filters' steps (filterpy-based)."""

import numpy as np
import pytest

from tracker_filter.banks import LinearGaussianBank, ObjectBank
from tracker_filter.filters import FilterConfig, FilterKind
from tracker_filter.gains import resolve_gains

CONFIGS = [
    FilterConfig(kind="kalman_cv", measurement_noise=2.0, process_noise=80.0),
    FilterConfig(kind="kalman_ca", measurement_noise=1.5, process_noise=300.0),
    FilterConfig(kind="alpha_beta", gains=resolve_gains(0.5, "benedict_bordner"), startup=True),
    FilterConfig(kind="alpha_beta", gains=resolve_gains(0.6, "kalata"), startup=False),
    FilterConfig(kind="alpha_beta_gamma", gains=resolve_gains(0.5, "critical_damping", order=2)),
]


@pytest.mark.parametrize("config", CONFIGS, ids=lambda c: f"{c.kind.value}-startup{c.startup}")
def test_bank_equals_one_filter_per_track(config):
    rng = np.random.default_rng(11)
    bank = config.new_bank()
    assert isinstance(bank, LinearGaussianBank)
    objects = ObjectBank(config.new_filter, config.state_layout)
    singles = []
    times = np.cumsum(rng.uniform(0.08, 0.2, size=25))
    for step, t in enumerate(times):
        for b in (bank, objects):
            b.predict(t)
        for f in singles:
            f.predict(t)
        if singles:
            measured = np.flatnonzero(rng.random(len(singles)) < 0.7)
            z = rng.normal(loc=bank.means[measured, :2], scale=3.0)
            bank.update(measured, z)
            objects.update(measured, z)
            for row, f in enumerate(singles):
                hit = np.flatnonzero(measured == row)
                f.update(z[hit[0]] if hit.size else None)
        if step % 6 == 0:  # tracks start at different times
            new = rng.uniform(0, 500, size=(2, 2))
            bank.add(new)
            objects.add(new)
            singles.extend(config.new_filter(p, t) for p in new)
        if step == 14:  # and some end
            keep = np.ones(len(singles), dtype=bool)
            keep[[0, 2]] = False
            bank.keep(keep)
            objects.keep(keep)
            singles = [f for f, k in zip(singles, keep, strict=True) if k]
        means = np.array([f.mean for f in singles])
        covariances = np.array([f.covariance for f in singles])
        for b in (bank, objects):
            np.testing.assert_allclose(b.means, means, rtol=1e-9, atol=1e-9)
            np.testing.assert_allclose(b.covariances, covariances, rtol=1e-7, atol=1e-9)
        z_pred, S = bank.measurement_prediction()
        np.testing.assert_allclose(z_pred, means[:, :2])
        np.testing.assert_allclose(
            S, covariances[:, :2, :2] + config.measurement_noise**2 * np.eye(2), rtol=1e-7
        )


def test_bank_rejects_time_going_back():
    bank = FilterConfig(kind=FilterKind.KALMAN_CV).new_bank()
    bank.predict(1.0)
    bank.add(np.array([[1.0, 2.0]]))
    bank.predict(2.0)
    with pytest.raises(ValueError, match="cannot predict"):
        bank.predict(1.5)
    assert bank.time == 2.0 and len(bank) == 1
