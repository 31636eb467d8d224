"""The GM-PHD filter of Vo & Ma (2006): each step against its equations written out plainly."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import multivariate_normal

from tracker_filter.gm_phd.gmphd import (
    DetectionTerms,
    GmPhdConfig,
    GmPhdFilter,
    Mixture,
    extract,
    merge,
    prune,
)
from tracker_filter.models import CONSTANT_VELOCITY

CONFIG = GmPhdConfig(clutter_rate=10.0, area=1000.0 * 1000.0, process_noise=2.0)


def mixture(weights, means, stds=(5.0, 5.0, 2.0, 2.0), tags=None) -> Mixture:
    count = len(weights)
    covariances = np.broadcast_to(np.diag(np.square(stds)), (count, 4, 4)).copy()
    return Mixture.of(np.array(weights, float), np.array(means, float), covariances, tags)


def plain_update(predicted: Mixture, z: np.ndarray, config: GmPhdConfig):
    """Vo & Ma's Table I update, one component and one measurement at a time."""
    r = config.measurement_noise**2 * np.eye(2)
    h = np.eye(2, 4)
    out = [((1 - config.detection) * w, m, p) for w, m, p in zip(*_parts(predicted), strict=True)]
    for zi in z:
        terms = []
        for w, m, p in zip(*_parts(predicted), strict=True):
            s = r + h @ p @ h.T
            k = p @ h.T @ np.linalg.inv(s)
            q = multivariate_normal.pdf(zi, mean=h @ m, cov=s)
            terms.append((config.detection * w * q, m + k @ (zi - h @ m), (np.eye(4) - k @ h) @ p))
        total = config.clutter_density + sum(t[0] for t in terms)
        out += [(t[0] / total, t[1], t[2]) for t in terms]
    return out


def _parts(m: Mixture):
    return m.weights, m.means, m.covariances


def test_update_is_vo_and_ma_table_one():
    phd = GmPhdFilter(CONFIG)
    predicted = mixture([0.9, 0.4], [[100, 100, 3, 0], [130, 95, 0, 2]])
    z = np.array([[102.0, 101.0], [128.0, 97.0], [500.0, 500.0]])
    result = phd.update(predicted, z)
    expected = [t for t in plain_update(predicted, z, CONFIG) if t[0] >= CONFIG.prune_threshold]
    got = sorted(zip(*_parts(result.mixture), strict=True), key=lambda t: -t[0])
    expected.sort(key=lambda t: -t[0])
    assert len(got) == len(expected)
    for (w, m, p), (we, me, pe) in zip(got, expected, strict=True):
        assert w == pytest.approx(we, rel=1e-9)
        assert np.allclose(m, me) and np.allclose(p, pe)
    # each measurement's detected weights sum to what targets explain of it, clutter the rest
    assert result.explained[2] < 1e-6 and 0.5 < result.explained[0] < 1.0


def test_predict_moves_survivors_and_keeps_births_unweighted_by_survival():
    birth = mixture([0.1], [[0, 0, 0, 0]])
    phd = GmPhdFilter(CONFIG, static_birth=birth)
    phd.mixture = mixture([1.0], [[10, 20, 3, -1]])
    predicted = phd.predict(2.0)
    f = CONSTANT_VELOCITY.transition(2.0)
    q = CONSTANT_VELOCITY.process_noise(2.0, CONFIG.process_noise)
    assert predicted.weights.tolist() == pytest.approx([CONFIG.survival, 0.1])
    assert np.allclose(predicted.means[0], f @ [10, 20, 3, -1])
    assert np.allclose(predicted.covariances[0], f @ phd.mixture.covariances[0] @ f.T + q)


def test_merge_sums_weights_without_a_cap_and_matches_moments():
    near = mixture([0.9, 0.8, 0.05], [[0, 0, 0, 0], [1, 1, 0, 0], [100, 0, 0, 0]])
    merged = merge(near, 4.0)
    assert len(merged) == 2
    heavy = int(np.argmax(merged.weights))
    assert merged.weights[heavy] == pytest.approx(1.7)  # summed, not capped at 1
    w = np.array([0.9, 0.8])
    mean = (w[:, None] * near.means[:2]).sum(axis=0) / w.sum()
    spread = near.means[:2] - mean
    cov = (
        sum(wi * (near.covariances[i] + np.outer(spread[i], spread[i])) for i, wi in enumerate(w))
        / w.sum()
    )
    assert np.allclose(merged.means[heavy], mean) and np.allclose(merged.covariances[heavy], cov)


def test_components_of_different_tags_never_merge():
    same_place = mixture([0.9, 0.8], [[0, 0, 0, 0], [0, 0, 0, 0]], tags=np.array([0, 7]))
    assert len(merge(same_place, 4.0)) == 2


def test_prune_drops_light_components_and_caps_at_the_heaviest():
    m = mixture([1e-6, 0.3, 0.9, 0.5], [[i, 0, 0, 0] for i in range(4)])
    kept = prune(m, 1e-5, 2)
    assert sorted(kept.weights.tolist()) == [0.5, 0.9]


def test_extract_gives_round_w_copies_above_the_threshold():
    m = mixture([0.4, 0.6, 1.6, 2.7], [[i, 0, 0, 0] for i in range(4)])
    found = extract(m, 0.5)
    assert sorted(found.means[:, 0].tolist()) == [1, 2, 2, 3, 3, 3]


def test_births_pair_unexplained_measurements_of_two_scans():
    phd = GmPhdFilter(replace_config(birth_weight=0.2, max_birth_speed=50.0))
    phd.step(np.array([[100.0, 100.0], [600.0, 600.0]]), 1.0)
    phd.step(np.array([[110.0, 95.0], [900.0, 100.0]]), 1.0)
    births = phd._birth_pairs
    assert len(births) == 1  # 600,600 -> 900,100 is too fast a pair
    assert np.allclose(births.means[0], [110, 95, 10, -5])
    assert births.weights[0] == pytest.approx(0.2)


def replace_config(**changes) -> GmPhdConfig:
    from dataclasses import replace

    return replace(CONFIG, **changes)


def test_a_target_in_clutter_is_found_and_followed():
    """Found within five scans; afterwards one estimate on it in most scans (a false alarm near a
    target takes almost its whole weight now and then: the PHD's known weakness, which the
    tracker's labelling absorbs) and the nearest estimate within the measurement noise."""
    rng = np.random.default_rng(5)
    phd = GmPhdFilter(replace_config(birth_weight=0.1, max_birth_speed=30.0))
    errors, counts = [], []
    for k in range(40):
        truth = np.array([200.0 + 8 * k, 300.0 + 3 * k])
        clutter = rng.uniform(0, 1000, (10, 2))
        z = np.vstack([truth + rng.normal(0, CONFIG.measurement_noise, 2), clutter])
        found = phd.step(z, 1.0)
        if k >= 5:
            counts.append(len(found))
            errors.append(np.hypot(*(found.means[:, :2] - truth).T).min())
    assert np.mean(np.array(counts) == 1) >= 0.85
    assert np.mean(errors) < CONFIG.measurement_noise


def test_guarded_components_leave_the_visible_targets_measurement_alone():
    phd = GmPhdFilter(CONFIG)
    visible_and_hidden = mixture([1.0, 1.0], [[100, 100, 0, 0], [104, 100, 0, 0]])
    z = np.array([[101.0, 100.0], [140.0, 100.0]])
    terms = DetectionTerms(np.array([0.98, 0.3]), np.array([0.02, 0.9]), np.array([False, True]))
    result = phd.update(visible_and_hidden, z, terms)
    hidden = result.mixture.subset(np.flatnonzero(result.mixture.means[:, 0] > 102))
    # the hidden one keeps 0.9 of its weight (persistence) and takes nothing of the blob at 101
    assert (hidden.sources != 0).all()
    missed = hidden.weights[hidden.sources == -1]
    assert missed.max() == pytest.approx(0.9)


def test_spawning_is_off_by_default_and_adds_components_when_on():
    phd = GmPhdFilter(CONFIG)
    phd.mixture = mixture([1.0], [[0, 0, 0, 0]])
    assert len(phd.predict(1.0)) == 1
    phd = GmPhdFilter(replace_config(spawn_weight=0.05))
    phd.mixture = mixture([1.0], [[0, 0, 0, 0]])
    spawned = phd.predict(1.0)
    assert len(spawned) == 2 and spawned.weights[1] == pytest.approx(0.05)


@pytest.mark.parametrize(
    "change", [{"detection": 0.0}, {"area": 0.0}, {"max_components": 0}, {"gate": -1.0}]
)
def test_bad_configurations_are_refused(change):
    with pytest.raises(ValueError, match=next(iter(change))):
        GmPhdFilter(replace_config(**change))


def test_the_same_scans_give_the_same_estimates():
    rng = np.random.default_rng(1)
    scans = [rng.uniform(0, 1000, (12, 2)) for _ in range(15)]
    runs = []
    for _ in range(2):
        phd = GmPhdFilter(replace_config(birth_weight=0.1))
        runs.append([phd.step(z, 1.0).means.tolist() for z in scans])
    assert runs[0] == runs[1]
    assert math.isfinite(GmPhdFilter(CONFIG).config.clutter_density)


def test_after_the_warm_up_the_filter_compiles_nothing():
    """`gm_phd`'s `warm_up` (called by the node before it subscribes) compiles the merge kernel
    for the types every merge passes, so no scan of a lockstep replay waits for numba."""
    from tracker_filter.gm_phd import gmphd

    gmphd.warm_up()
    before = len(gmphd._merge_groups.signatures)
    phd = GmPhdFilter(replace_config(birth_weight=0.2, max_birth_speed=50.0))
    for k in range(6):  # two targets, then a third: births, updates, merges
        scan = np.array([[100.0 + 5 * k, 100.0], [600.0 - 5 * k, 600.0], [300.0, 300.0 + 4 * k]])
        phd.step(scan, 1.0)
    assert before == len(gmphd._merge_groups.signatures) == 1
