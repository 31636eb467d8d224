"""Measurement-to-track association: Mahalanobis gating + Hungarian assignment (no rclpy)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.stats import chi2

from tracker_filter.linear_gaussian import inverse_2x2
from tracker_filter.models import AXES


def gate_threshold(probability: float, dof: int = AXES) -> float:
    """Squared Mahalanobis distance holding a true measurement with `probability` (chi-square);
    probability 1 means no gate (infinity)."""
    if not 0.0 < probability <= 1.0:
        raise ValueError(f"gate probability must be in (0, 1], got {probability}")
    return math.inf if probability == 1.0 else float(chi2.ppf(probability, dof))


def mahalanobis_squared(
    z_predicted: np.ndarray, innovation_covariances: np.ndarray, z: np.ndarray
) -> np.ndarray:
    """d^2[i, j] = (z_j - zp_i)^T S_i^-1 (z_j - zp_i), shape (tracks, measurements).

    In closed form for 2-D measurements, with S^-1 = [[a, b], [b, d]]:
    d^2 = a dx^2 + 2 b dx dy + d dy^2 (a quarter of the time of the general einsum)."""
    s_inverse = inverse_2x2(innovation_covariances)
    a = s_inverse[:, 0, 0, None]
    b = s_inverse[:, 0, 1, None] + s_inverse[:, 1, 0, None]  # 2b, symmetric or not
    d = s_inverse[:, 1, 1, None]
    dx = z[None, :, 0] - z_predicted[:, 0, None]
    dy = z[None, :, 1] - z_predicted[:, 1, None]
    distances: np.ndarray = a * dx * dx + b * dx * dy + d * dy * dy
    return distances


@dataclass(frozen=True)
class Association:
    """Pairs (tracks[k], measurements[k]); every other track missed, every other measurement is free."""

    tracks: np.ndarray
    measurements: np.ndarray

    def unassigned_measurements(self, count: int) -> np.ndarray:
        free = np.ones(count, dtype=bool)
        free[self.measurements] = False
        return np.flatnonzero(free)


class Associator(Protocol):
    def associate(
        self, z_predicted: np.ndarray, innovation_covariances: np.ndarray, z: np.ndarray
    ) -> Association: ...


DENSE_PAIRS = 256  # up to this many track-measurement pairs, gate on the full matrix


def gated_pairs(
    z_predicted: np.ndarray, innovation_covariances: np.ndarray, z: np.ndarray, gate: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The (track, measurement) pairs with d^2 <= gate and their d^2, tracks ascending.

    Without forming the tracks x measurements matrix: d^2 <= g bounds |dx| by sqrt(g S_xx) and
    |dy| by sqrt(g S_yy), so each track looks only at the measurements whose x falls in its
    window (a binary search in the measurements sorted by x), then at dy, then at d^2. The cost
    grows with the tracks, the measurements and the candidate pairs, not their product.
    """
    tracks, count = len(z_predicted), len(z)
    if tracks * count <= DENSE_PAIRS or not math.isfinite(gate):
        # few pairs (or no gate): the whole matrix costs less than the search
        d2 = mahalanobis_squared(z_predicted, innovation_covariances, z)
        rows, cols = np.nonzero(d2 <= gate)
        return rows, cols, d2[rows, cols]
    order = np.argsort(z[:, 0], kind="stable")
    xs = z[order, 0]
    reach_x = np.sqrt(gate * innovation_covariances[:, 0, 0])
    low = np.searchsorted(xs, z_predicted[:, 0] - reach_x, side="left")
    high = np.searchsorted(xs, z_predicted[:, 0] + reach_x, side="right")
    widths = high - low
    rows = np.repeat(np.arange(tracks), widths)
    starts = np.repeat(low - (np.cumsum(widths) - widths), widths)
    cols = order[starts + np.arange(len(rows))]
    reach_y = np.sqrt(gate * innovation_covariances[rows, 1, 1])
    near = np.abs(z[cols, 1] - z_predicted[rows, 1]) <= reach_y
    rows, cols = rows[near], cols[near]
    s_inverse = inverse_2x2(innovation_covariances)[rows]
    dx = z[cols, 0] - z_predicted[rows, 0]
    dy = z[cols, 1] - z_predicted[rows, 1]
    d2 = (
        s_inverse[:, 0, 0] * dx * dx
        + (s_inverse[:, 0, 1] + s_inverse[:, 1, 0]) * dx * dy
        + s_inverse[:, 1, 1] * dy * dy
    )
    inside = d2 <= gate
    return rows[inside], cols[inside], d2[inside]


class GatedHungarianAssociator:
    """Global nearest neighbour: the assignment minimising the total negative log-likelihood
    d^2 + ln det S (scipy's linear_sum_assignment) among pairs inside the chi-square gate.

    The ln det S term keeps an uncertain (long-coasting) track from taking a measurement that a
    well-localised track explains better.
    """

    def __init__(self, gate_probability: float = 0.99) -> None:
        self.gate = gate_threshold(gate_probability)

    def associate(
        self, z_predicted: np.ndarray, innovation_covariances: np.ndarray, z: np.ndarray
    ) -> Association:
        empty = np.zeros(0, dtype=np.int64)
        if len(z_predicted) == 0 or len(z) == 0:
            return Association(empty, empty)
        rows, cols, d2 = gated_pairs(z_predicted, innovation_covariances, z, self.gate)
        if len(rows) == 0:
            return Association(empty, empty)
        det = (
            innovation_covariances[:, 0, 0] * innovation_covariances[:, 1, 1]
            - innovation_covariances[:, 0, 1] * innovation_covariances[:, 1, 0]
        )
        cost = d2 + np.log(det)[rows]
        # A track whose only candidate has no other candidate track is in every optimum: pair it
        # directly; only the contested pairs go to the assignment.
        alone = (np.bincount(rows)[rows] == 1) & (np.bincount(cols)[cols] == 1)
        paired_tracks, paired_measurements = [rows[alone]], [cols[alone]]
        if not alone.all():
            contested = ~alone
            tracks, measurements = self._assign(rows[contested], cols[contested], cost[contested])
            paired_tracks.append(tracks)
            paired_measurements.append(measurements)
        tracks = np.concatenate(paired_tracks).astype(np.int64)
        measurements = np.concatenate(paired_measurements).astype(np.int64)
        order = np.argsort(tracks, kind="stable")
        return Association(tracks[order], measurements[order])

    @staticmethod
    def _assign(
        rows: np.ndarray, cols: np.ndarray, cost: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """The most gated pairs at the least total cost among the given ones (Hungarian)."""
        tracks, row_at = np.unique(rows, return_inverse=True)
        measurements, col_at = np.unique(cols, return_inverse=True)
        inside = np.zeros((len(tracks), len(measurements)), dtype=bool)
        inside[row_at, col_at] = True
        matrix = np.zeros(inside.shape)
        matrix[row_at, col_at] = cost - cost.min()
        # Pairs outside the gate get a cost larger than any sum of gated pairs, so the optimum
        # assigns as many gated pairs as possible; they are dropped afterwards.
        forbidden = (matrix[inside].max() + 1.0) * (min(matrix.shape) + 1)
        chosen_rows, chosen_cols = linear_sum_assignment(np.where(inside, matrix, forbidden))
        kept = inside[chosen_rows, chosen_cols]
        return tracks[chosen_rows[kept]], measurements[chosen_cols[kept]]
