"""Mahalanobis gating and Hungarian assignment against direct references."""

import itertools
import math

import numpy as np
import pytest
from scipy.spatial.distance import mahalanobis

from tracker_filter.gated_hungarian.association import (
    GatedHungarianAssociator,
    gate_threshold,
    mahalanobis_squared,
)


def random_covariances(rng, count):
    a = rng.normal(size=(count, 2, 2)) * 3.0
    return a @ np.swapaxes(a, 1, 2) + np.eye(2)


def test_gate_threshold_is_the_chi_square_quantile():
    assert gate_threshold(0.99) == pytest.approx(-2 * math.log(0.01))  # chi2 with 2 dof
    assert gate_threshold(0.95) == pytest.approx(5.991, abs=1e-3)
    assert gate_threshold(1.0) == math.inf
    for bad in (0.0, 1.5, -0.1):
        with pytest.raises(ValueError, match="gate probability"):
            gate_threshold(bad)


def test_mahalanobis_matches_scipy():
    rng = np.random.default_rng(0)
    z_pred, S, z = (
        rng.normal(size=(4, 2)) * 10,
        random_covariances(rng, 4),
        rng.normal(size=(6, 2)) * 10,
    )
    d2 = mahalanobis_squared(z_pred, S, z)
    for i, j in itertools.product(range(4), range(6)):
        assert d2[i, j] == pytest.approx(mahalanobis(z[j], z_pred[i], np.linalg.inv(S[i])) ** 2)


def brute_force(z_pred, S, z, gate):
    """The gated assignment with the most pairs, then the least total cost, by enumeration."""
    d2 = mahalanobis_squared(z_pred, S, z)
    cost = d2 + np.log(np.linalg.det(S))[:, None]
    best = (0, 0.0, set())
    n, m = d2.shape
    for size in range(1, min(n, m) + 1):
        for rows in itertools.combinations(range(n), size):
            for cols in itertools.permutations(range(m), size):
                if all(d2[r, c] <= gate for r, c in zip(rows, cols, strict=True)):
                    total = sum(cost[r, c] for r, c in zip(rows, cols, strict=True))
                    if size > best[0] or (size == best[0] and total < best[1]):
                        best = (size, total, set(zip(rows, cols, strict=True)))
    return best[2]


def test_assignment_is_the_gated_optimum():
    rng = np.random.default_rng(1)
    associator = GatedHungarianAssociator(0.95)
    for _ in range(40):
        n, m = rng.integers(1, 5), rng.integers(1, 5)
        z_pred = rng.uniform(0, 30, size=(n, 2))
        S = random_covariances(rng, n)
        z = rng.uniform(0, 30, size=(m, 2))
        result = associator.associate(z_pred, S, z)
        pairs = set(zip(result.tracks.tolist(), result.measurements.tolist(), strict=True))
        assert pairs == brute_force(z_pred, S, z, associator.gate)
        d2 = mahalanobis_squared(z_pred, S, z)
        assert all(d2[r, c] <= associator.gate for r, c in pairs)
        free = result.unassigned_measurements(m)
        assert set(free.tolist()) == set(range(m)) - {c for _, c in pairs}


def test_without_gate_everything_pairs_and_empty_inputs_work():
    associator = GatedHungarianAssociator(1.0)
    result = associator.associate(np.array([[0.0, 0.0]]), np.eye(2)[None], np.array([[1e4, 1e4]]))
    assert result.tracks.tolist() == [0] and result.measurements.tolist() == [0]
    empty = associator.associate(np.zeros((0, 2)), np.zeros((0, 2, 2)), np.array([[1.0, 1.0]]))
    assert empty.tracks.size == 0 and empty.unassigned_measurements(1).tolist() == [0]


def test_gated_pairs_are_exactly_the_dense_matrix_inside_the_gate():
    from tracker_filter.gated_hungarian.association import gated_pairs

    rng = np.random.default_rng(5)
    gate = gate_threshold(0.99)
    for tracks, count in ((60, 90), (1, 1), (5, 0), (40, 3)):
        z_pred = rng.uniform(0, 400, size=(tracks, 2))
        S = random_covariances(rng, tracks) * rng.uniform(1, 30, size=(tracks, 1, 1))
        z = np.vstack([z_pred[: count // 2] + rng.normal(size=(min(count // 2, tracks), 2))])
        z = np.vstack([z, rng.uniform(0, 400, size=(count - len(z), 2))])
        rows, cols, d2 = gated_pairs(z_pred, S, z, gate)
        dense = mahalanobis_squared(z_pred, S, z)
        expected = {(r, c) for r, c in zip(*np.nonzero(dense <= gate), strict=True)}
        assert set(zip(rows.tolist(), cols.tolist(), strict=True)) == expected
        assert np.allclose(d2, dense[rows, cols])
        assert list(rows) == sorted(rows)
