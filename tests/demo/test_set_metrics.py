"""Seed 004's point-set metrics: OSPA by its definition and against Stone Soup; FAR, ReR, MLR, MOR."""

from __future__ import annotations

import datetime
import itertools

import numpy as np
import pytest

from tracker_ptz_sim.evaluation.set_metrics import ospa, score_points, true_runs


def brute_force_ospa(x: np.ndarray, y: np.ndarray, c: float, p: float) -> float:
    """The definition: min over every assignment of the smaller set into the larger."""
    if len(x) > len(y):
        x, y = y, x
    m, n = len(x), len(y)
    if n == 0:
        return 0.0
    best = min(
        sum(min(c, float(np.linalg.norm(x[i] - y[j]))) ** p for i, j in enumerate(perm))
        for perm in itertools.permutations(range(n), m)
    )
    return ((best + c**p * (n - m)) / n) ** (1 / p)


@pytest.mark.parametrize("seed", range(20))
def test_ospa_is_its_definition(seed):
    rng = np.random.default_rng(seed)
    x = rng.uniform(0, 300, (rng.integers(0, 5), 2))
    y = rng.uniform(0, 300, (rng.integers(0, 5), 2))
    for p in (1.0, 2.0):
        assert ospa(x, y, 100.0, p) == pytest.approx(brute_force_ospa(x, y, 100.0, p))


def test_ospa_edge_cases():
    assert ospa(np.zeros((0, 2)), np.zeros((0, 2)), 10.0) == 0.0
    assert ospa(np.zeros((0, 2)), np.ones((3, 2)), 10.0) == 10.0
    assert ospa(np.array([[0.0, 0.0]]), np.array([[3.0, 4.0]]), 10.0) == pytest.approx(5.0)


def test_ospa_of_order_one_equals_stone_soups():
    pytest.importorskip("stonesoup")  # a benchmark dependency, not a runtime one
    from stonesoup.measures import Euclidean
    from stonesoup.metricgenerator.ospametric import OSPAMetric
    from stonesoup.types.state import State

    stamp = datetime.datetime(2026, 1, 1)
    metric = OSPAMetric(c=50.0, p=1, measure=Euclidean())
    rng = np.random.default_rng(3)
    for _ in range(30):
        x = rng.uniform(0, 200, (rng.integers(1, 6), 2))
        y = rng.uniform(0, 200, (rng.integers(1, 6), 2))
        states = [[State(p.reshape(2, 1), timestamp=stamp) for p in s] for s in (x, y)]
        theirs = metric.compute_OSPA_distance(states[1], states[0]).value
        assert ospa(x, y, 50.0, 1.0) == pytest.approx(theirs)


def pts(**points) -> dict[int, np.ndarray]:
    return {int(k[1:]): np.array(v, float) for k, v in points.items()}


def test_rates_on_a_hand_made_sequence():
    truth = [pts(t1=[0, 0], t2=[100, 0]) for _ in range(4)]
    estimates = [
        pts(t7=[1, 0], t8=[101, 0]),
        pts(t7=[1, 0], t9=[500, 500]),  # t2 missed, one false estimate
        pts(t7=[1, 0], t8=[101, 0]),
        pts(t8=[1, 0], t7=[101, 0]),  # labels swapped
    ]
    scores = score_points(truth, estimates, match_distance=10.0, ospa_cutoff=100.0)
    assert scores.far == pytest.approx(1 / 8)
    assert scores.rer == pytest.approx(7 / 8)
    # t1's label is 7 (3 frames), t2's is 8 (2 frames): lost-label frames 1 + 2 of 8
    assert scores.mlr == pytest.approx(3 / 8)
    assert scores.mota == pytest.approx(1 - (1 + 1 + 2) / 8)


def test_missed_occlusions_compare_labels_before_and_after():
    truth = [pts(t1=[0, 0]) for _ in range(10)]
    kept = [pts(t5=[0, 0]) for _ in range(10)]
    changed = [pts(t5=[0, 0]) for _ in range(4)] + [pts(t6=[0, 0]) for _ in range(6)]
    occlusion = [(1, 3, 5)]  # target 1 hidden in frames 3..5
    assert score_points(truth, kept, 5.0, 50.0, occlusion).mor == 0.0
    assert score_points(truth, changed, 5.0, 50.0, occlusion).mor == 1.0


def test_true_runs_are_the_first_and_last_index_of_each_run():
    assert true_runs([False, True, True, False, True]) == [(1, 2), (4, 4)]
    assert true_runs([True, True]) == [(0, 1)]
    assert true_runs([]) == [] and true_runs([False]) == []
