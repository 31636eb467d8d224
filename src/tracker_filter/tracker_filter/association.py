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
    """d^2[i, j] = (z_j - zp_i)^T S_i^-1 (z_j - zp_i), shape (tracks, measurements)."""
    residual = z[None, :, :] - z_predicted[:, None, :]
    s_inverse = inverse_2x2(innovation_covariances)
    return np.einsum("tmi,tij,tmj->tm", residual, s_inverse, residual)


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
        d2 = mahalanobis_squared(z_predicted, innovation_covariances, z)
        det = (
            innovation_covariances[:, 0, 0] * innovation_covariances[:, 1, 1]
            - innovation_covariances[:, 0, 1] * innovation_covariances[:, 1, 0]
        )
        cost = d2 + np.log(det)[:, None]
        inside = d2 <= self.gate
        if not inside.any():
            return Association(empty, empty)
        # Pairs outside the gate get a cost larger than any sum of gated pairs, so the optimum
        # assigns as many gated pairs as possible; they are dropped afterwards.
        cost = cost - cost[inside].min()
        forbidden = (cost[inside].max() + 1.0) * (min(cost.shape) + 1)
        rows, cols = linear_sum_assignment(np.where(inside, cost, forbidden))
        kept = inside[rows, cols]
        return Association(rows[kept].astype(np.int64), cols[kept].astype(np.int64))
