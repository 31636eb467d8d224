"""Gain rules of the fixed-gain (alpha-beta and alpha-beta-gamma) filters (no rclpy).

Conventions (filterpy's g-h-k filters, seed 000 section 3): with residual r = z - x_predicted,

    x += alpha r        v += beta r / dt        a += 2 gamma r / dt^2

so alpha and beta are the seed's alpha and beta, and gamma is filterpy's k.

beta rules of seed 000 (alpha in (0, 1)):
- Kalata: beta = 2(2 - alpha) - 4 sqrt(1 - alpha), the steady-state Kalman gain of the white-acceleration
  model (digest erratum: the printed "2(2-alpha)4 sqrt(1-alpha)" lacks the minus);
- Benedict-Bordner: beta = alpha^2 / (2 - alpha) (filterpy.gh.benedict_bornder_constants);
- critical damping (Sklansky): beta = 2 - alpha - 2 sqrt(1 - alpha) (filterpy.gh.critical_damping_parameters).
For alpha-beta-gamma, "kalata" adds gamma = beta^2 / (4 alpha) (close to the white-jerk steady-state
Kalman gains) and "critical_damping" takes all three gains from filterpy's order-3 fading-memory rule.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from filterpy.gh import (
    benedict_bornder_constants,
    critical_damping_parameters,
    least_squares_parameters,
)


class GainRule(StrEnum):
    KALATA = "kalata"
    BENEDICT_BORDNER = "benedict_bordner"
    CRITICAL_DAMPING = "critical_damping"
    FREE = "free"


@dataclass(frozen=True)
class GhGains:
    """Gains of a fixed-gain filter; gamma is None for alpha-beta (order 1)."""

    alpha: float
    beta: float
    gamma: float | None = None

    @property
    def order(self) -> int:
        return 1 if self.gamma is None else 2

    def as_tuple(self) -> tuple[float, ...]:
        return (
            (self.alpha, self.beta) if self.gamma is None else (self.alpha, self.beta, self.gamma)
        )


def kalata_beta(alpha: float) -> float:
    return 2.0 * (2.0 - alpha) - 4.0 * math.sqrt(1.0 - alpha)


def kalata_alpha(tracking_index: float) -> float:
    """Kalata's optimal alpha for tracking index Lambda = sigma_w dt^2 / sigma_n (seed 000 section 3)."""
    l2 = tracking_index**2 + 8.0 * tracking_index
    return (-l2 + math.sqrt(l2 * l2 + 16.0 * l2)) / 8.0


def tracking_index(process_noise: float, measurement_noise: float, dt: float) -> float:
    """Kalata's tracking index Lambda = sigma_w dt^2 / sigma_n."""
    return process_noise * dt * dt / measurement_noise


def seed_stability_condition(alpha: float, beta: float) -> bool:
    """Seed 000's analytic stability test of the alpha-beta filter:
    alpha > 0, beta > 0, 4 - 2 alpha - beta > 0."""
    return alpha > 0.0 and beta > 0.0 and 4.0 - 2.0 * alpha - beta > 0.0


def closed_loop_matrix(gains: GhGains) -> np.ndarray:
    """Per-axis error dynamics (I - K H) F at dt = 1; the filter is stable iff its spectral radius < 1.

    For alpha-beta this is [[1 - alpha, (1 - alpha) T], [-beta / T, 1 - beta]] with T = 1 (seed 000
    erratum: row (2,1) is -beta/T). The eigenvalues do not depend on T.
    """
    order = gains.order
    transition = np.eye(order + 1)
    for power in range(1, order + 1):
        transition += np.diag(np.full(order + 1 - power, 1.0 / math.factorial(power)), power)
    weights = np.array([gains.alpha, gains.beta, 2.0 * (gains.gamma or 0.0)])[: order + 1]
    return (np.eye(order + 1) - np.outer(weights, np.eye(1, order + 1))) @ transition


def spectral_radius(gains: GhGains) -> float:
    return float(np.max(np.abs(np.linalg.eigvals(closed_loop_matrix(gains)))))


def is_stable(gains: GhGains) -> bool:
    return all(g > 0.0 for g in gains.as_tuple()) and spectral_radius(gains) < 1.0


def resolve_gains(
    alpha: float,
    rule: GainRule | str,
    order: int = 1,
    beta: float | None = None,
    gamma: float | None = None,
) -> GhGains:
    """The gains for `alpha` under `rule` (beta and gamma are read only for the free rule).

    Raises ValueError naming the problem for an alpha outside a rule's domain, a rule the order does
    not define, missing free gains, or gains whose filter would be unstable.
    """
    rule = GainRule(rule)
    if order not in (1, 2):
        raise ValueError(
            f"filter order must be 1 (alpha-beta) or 2 (alpha-beta-gamma), got {order}"
        )
    if rule is not GainRule.FREE and not 0.0 < alpha < 1.0:
        raise ValueError(f"the {rule.value} rule needs 0 < alpha < 1, got alpha = {alpha}")
    if rule is GainRule.FREE:
        if beta is None or (order == 2 and gamma is None):
            raise ValueError("the free rule needs beta (and gamma for alpha-beta-gamma)")
        gains = GhGains(alpha, beta, gamma if order == 2 else None)
    elif rule is GainRule.KALATA:
        b = kalata_beta(alpha)
        gains = GhGains(alpha, b, b * b / (4.0 * alpha) if order == 2 else None)
    elif rule is GainRule.BENEDICT_BORDNER:
        if order == 2:
            raise ValueError("the benedict_bordner rule is defined for alpha-beta only")
        gains = GhGains(alpha, benedict_bornder_constants(alpha)[1])
    else:
        # filterpy parameterises critical damping by the discount theta: alpha = 1 - theta^(order+1).
        theta = (1.0 - alpha) ** (1.0 / (order + 1))
        _, h, *k = critical_damping_parameters(theta, order=order + 1)
        gains = GhGains(alpha, h, k[0] if order == 2 else None)
    if not is_stable(gains):
        radius = spectral_radius(gains)
        raise ValueError(
            f"gains {gains.as_tuple()} give an unstable filter (spectral radius {radius:.3f} >= 1)"
        )
    return gains


def startup_gains(order: int, n: int | np.ndarray) -> tuple:
    """Expanding-memory (least-squares) gains (g, h, k) for the n-th measurement, n = 0 the first.

    A g-h(-k) filter run with these gains reproduces the least-squares polynomial fit of all the
    measurements so far (uniform spacing; Brookner, "Tracking and Kalman Filters Made Easy", 1998),
    so a track's velocity is the two-point difference after its second measurement instead of
    creeping up from zero. k is 0 for order 1. `n` may be an array (one gain per track).
    """
    if order == 1:
        g, h = least_squares_parameters(n)  # plain arithmetic: works on arrays too
        return (g, h, 0.0 * g)
    d = (n + 1) * (n + 2) * (n + 3)
    return (3.0 * (3 * n * n + 3 * n + 2) / d, 18.0 * (2 * n + 1) / d, 30.0 / d)


def gain_schedule(gains: GhGains, n: int | np.ndarray, startup: bool) -> tuple:
    """Gains (g, h, k) for the n-th measurement of a track: the least-squares ones while their g
    exceeds alpha, then the steady gains. `n` may be an array (one gain per track)."""
    steady = (gains.alpha, gains.beta, gains.gamma or 0.0)
    if not startup:
        return tuple(np.broadcast_to(np.float64(value), np.shape(n)) for value in steady)
    scheduled = startup_gains(gains.order, np.asarray(n, dtype=float))
    use_startup = scheduled[0] > gains.alpha
    return tuple(
        np.where(use_startup, early, late) for early, late in zip(scheduled, steady, strict=True)
    )
