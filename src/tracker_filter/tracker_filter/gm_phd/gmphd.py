"""The Gaussian-mixture PHD filter of Vo & Ma (2006), vectorised (seed 004; no rclpy).

The PHD (intensity) of the multi-target state is a Gaussian mixture ``sum_j w_j N(x; m_j, P_j)``
whose total weight is the expected number of targets. State ``x y vx vy`` (scene px, px/s), the
constant-velocity model of `models.CONSTANT_VELOCITY` (the digest's F and Q, not the thesis's
inconsistent matrices), measurement H = [I 0], R = sigma_r^2 I, Poisson clutter of intensity
kappa = clutter_rate / area.

One `GmPhdFilter.step` is the recursion of Vo & Ma, Table I and II:

predict   survivors   w <- p_S w,  m <- F m,  P <- F P F^T + Q
          spawns      (optional) w_s w, F m, F P F^T + Q_s
          births      measurement-driven (pairs of unexplained measurements of the last two
                      scans within `max_birth_speed`: m = [z_k, (z_k - z_{k-1}) / dt]) and a
                      static birth mixture, both predicted like survivors
update    missed      (1 - p_D) w, m, P   (none for births: as Stone Soup, unlike Vo & Ma's
                      formula -- an undetected wide birth would widen the targets it merges into)
          detected    eta = H m, S = R + H P H^T, K = P H^T S^-1,
                      m' = m + K (z - eta), P' = (I - K H) P,
                      w' = p_D w N(z; eta, S) / (kappa + p_D sum_l w_l N(z; eta_l, S_l))
reduce    prune w < T; merge, heaviest first, every component i with
          (m_i - m_j)^T P_i^-1 (m_i - m_j) <= U into the heaviest j:
          w~ = sum w,  m~ = sum w m / w~,  P~ = sum w [P + (m~ - m)(m~ - m)^T] / w~
          (weights summed, never capped at 1); keep the J_max heaviest
extract   every component with w > 0.5, round(w) copies

Two additions for occlusion handling (`phd_occlusion`), both neutral when unused:
- every component carries a `tag` (0: none); only components with equal tags merge, so an
  occluded target's Gaussian is not swallowed by the one of the target that hides it;
- `update(..., terms=DetectionTerms(...))` sets p_D and the missed-detection factor per
  component, and guards components: an occluded target's Gaussian gets the digest's persistence
  factor P_d^occl on its missed-detection term, p_D = 1 - P_d^occl (hidden: hardly detectable,
  more so as the occlusion drags on), and only measurements no visible target explains.

Every detected component remembers the measurement that made it (`sources`, -1 for missed terms;
a merge keeps its heaviest detected member's when its detected members weigh 0.5 or more, else
the heaviest member's), so a tracker can tell a hit from a coast.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numba
import numpy as np

from tracker_filter.models import CONSTANT_VELOCITY

DIM = 4  # x y vx vy
AXES = 2
BIRTH = -2  # source of a birth component between prediction and update
DETECTED_SHARE = 0.5  # detected weight in a merged group that makes it a measured Gaussian


@dataclass(frozen=True, eq=False)
class Mixture:
    """Gaussian components: weights (J,), means (J, 4), covariances (J, 4, 4), tags (J,) and the
    measurement index that made each (J,), -1 for none."""

    weights: np.ndarray
    means: np.ndarray
    covariances: np.ndarray
    tags: np.ndarray
    sources: np.ndarray

    @classmethod
    def empty(cls) -> Mixture:
        return cls(
            np.zeros(0),
            np.zeros((0, DIM)),
            np.zeros((0, DIM, DIM)),
            np.zeros(0, np.int64),
            np.zeros(0, np.int64),
        )

    @classmethod
    def of(
        cls,
        weights: np.ndarray,
        means: np.ndarray,
        covariances: np.ndarray,
        tags: np.ndarray | None = None,
    ) -> Mixture:
        """Components with no tags and no source measurement unless given."""
        weights = np.asarray(weights, dtype=float).reshape(-1)
        count = len(weights)
        return cls(
            weights,
            np.asarray(means, dtype=float).reshape(count, DIM),
            np.asarray(covariances, dtype=float).reshape(count, DIM, DIM),
            np.zeros(count, np.int64) if tags is None else np.asarray(tags, np.int64),
            np.full(count, -1, np.int64),
        )

    def __len__(self) -> int:
        return len(self.weights)

    @property
    def expected_count(self) -> float:
        """Total weight: the expected number of targets."""
        return float(self.weights.sum())

    def subset(self, index: np.ndarray) -> Mixture:
        return Mixture(
            self.weights[index],
            self.means[index],
            self.covariances[index],
            self.tags[index],
            self.sources[index],
        )

    @staticmethod
    def concatenate(parts: list[Mixture]) -> Mixture:
        parts = [p for p in parts if len(p)]
        if not parts:
            return Mixture.empty()
        return Mixture(
            *(
                np.concatenate([getattr(p, name) for p in parts])
                for name in ("weights", "means", "covariances", "tags", "sources")
            )
        )


@dataclass(frozen=True)
class GmPhdConfig:
    """Parameters of `GmPhdFilter` (defaults: the digest's, Vo & Ma's base code where it is
    silent). Units: px, s; the thesis steps one frame per unit of time."""

    survival: float = 0.99  # p_S
    detection: float = 0.98  # p_D
    clutter_rate: float = 25.0  # lambda_c, false measurements per scan
    area: float = 2000.0 * 1000.0  # V, px^2 of the surveillance region (kappa = lambda_c / V)
    process_noise: float = 5.0  # sigma_v, px/s^2
    measurement_noise: float = 10.0  # sigma_r, px
    prune_threshold: float = 1e-5  # T
    merge_threshold: float = 4.0  # U (squared Mahalanobis distance)
    max_components: int = 100  # J_max
    extract_threshold: float = 0.5
    birth_weight: float = 0.03  # total weight of the births one measurement makes
    max_birth_speed: float = 100.0  # px/s between the two measurements of a birth
    birth_gate: float = 0.5  # a measurement this well explained by targets makes no birth
    spawn_weight: float = 0.0  # w_s: spawns per target (0: none)
    spawn_noise: float = 20.0  # sigma of the spawn's extra velocity, px/s
    gate: float = math.inf  # squared Mahalanobis distance beyond which z does not update m
    # Stone Soup's GaussianMixtureReducer caps a merged weight at 1; Vo & Ma (and this filter by
    # default) do not. Only for comparing with it like for like.
    cap_merged_weight: bool = False

    @property
    def clutter_density(self) -> float:
        """kappa, false measurements per px^2 per scan."""
        return self.clutter_rate / self.area

    def problems(self) -> list[str]:
        found = []
        for name in ("survival", "detection", "extract_threshold", "birth_gate"):
            value = getattr(self, name)
            if not 0.0 < value <= 1.0:
                found.append(f"{name} must be in (0, 1], got {value}")
        for name in ("area", "process_noise", "measurement_noise", "merge_threshold"):
            if not getattr(self, name) > 0.0:
                found.append(f"{name} must be > 0, got {getattr(self, name)}")
        for name in ("clutter_rate", "prune_threshold", "birth_weight", "spawn_weight"):
            if not getattr(self, name) >= 0.0:
                found.append(f"{name} must be >= 0, got {getattr(self, name)}")
        if self.max_components < 1:
            found.append(f"max_components must be >= 1, got {self.max_components}")
        if not self.gate > 0.0:
            found.append(f"gate must be > 0, got {self.gate}")
        if not self.max_birth_speed > 0.0:
            found.append(f"max_birth_speed must be > 0, got {self.max_birth_speed}")
        return found


def gaussian_likelihoods(
    means: np.ndarray,
    innovation_covariances: np.ndarray,
    measurements: np.ndarray,
    gate: float = math.inf,
) -> tuple[np.ndarray, np.ndarray]:
    """N(z; H m_j, S_j) for every component j and measurement z: (J, M), 0 beyond the squared
    Mahalanobis distance `gate`, and the innovations (J, M, 2). Closed-form 2x2 inverses."""
    a = innovation_covariances[:, 0, 0]
    b = innovation_covariances[:, 0, 1]
    d = innovation_covariances[:, 1, 1]
    det = a * d - b * b
    innovations = measurements[None, :, :] - means[:, None, :AXES]
    nx, ny = innovations[..., 0], innovations[..., 1]
    squared = (d[:, None] * nx * nx - 2.0 * b[:, None] * nx * ny + a[:, None] * ny * ny) / det[
        :, None
    ]
    likelihood = np.exp(-0.5 * squared) / (2.0 * math.pi * np.sqrt(det))[:, None]
    if math.isfinite(gate):
        likelihood[squared > gate] = 0.0
    return likelihood, innovations


@numba.njit(cache=True, nogil=True)
def _merge_groups(  # pragma: no cover (compiled; tested through merge())
    weights: np.ndarray,
    means: np.ndarray,
    inverses: np.ndarray,
    spreads: np.ndarray,
    tags: np.ndarray,
    threshold: float,
) -> np.ndarray:
    """Group of every component: heaviest first, each takes the ungrouped components of its tag
    within `threshold` (their own inverse covariances, as Vo & Ma). `spreads` are the traces of
    the covariances: d^2 >= |dx|^2 / trace(P), so farther pairs are skipped without d^2."""
    count = weights.shape[0]
    order = np.argsort(-weights, kind="mergesort")
    group = np.full(count, -1, np.int64)
    groups = 0
    for a in range(count):
        lead = order[a]
        if group[lead] >= 0:
            continue
        group[lead] = groups
        for b in range(a + 1, count):
            other = order[b]
            if group[other] >= 0 or tags[other] != tags[lead]:
                continue
            dx = means[other, 0] - means[lead, 0]
            dy = means[other, 1] - means[lead, 1]
            if dx * dx + dy * dy > threshold * spreads[other]:
                continue
            distance = 0.0
            for r in range(DIM):
                dr = means[other, r] - means[lead, r]
                for c in range(DIM):
                    distance += dr * inverses[other, r, c] * (means[other, c] - means[lead, c])
            if distance <= threshold:
                group[other] = groups
        groups += 1
    return group


def merge(mixture: Mixture, threshold: float) -> Mixture:
    """Vo & Ma's merging: weights summed, moment-matched means and covariances; a merged
    component keeps the tag of its members and the source of its heaviest."""
    if len(mixture) < 2:
        return mixture
    covariances = mixture.covariances
    spreads = np.trace(covariances, axis1=1, axis2=2)
    contiguous = np.ascontiguousarray  # one compiled signature (`warm_up`)
    group = _merge_groups(
        contiguous(mixture.weights),
        contiguous(mixture.means),
        contiguous(np.linalg.inv(covariances)),
        contiguous(spreads),
        contiguous(mixture.tags),
        float(threshold),
    )
    count = int(group.max()) + 1
    if count == len(mixture):
        return mixture
    w = mixture.weights
    weights = np.bincount(group, weights=w, minlength=count)
    means = np.zeros((count, DIM))
    np.add.at(means, group, w[:, None] * mixture.means)
    means /= weights[:, None]
    spread = mixture.means - means[group]
    weighted = mixture.covariances + spread[:, :, None] * spread[:, None, :]
    covariances = np.zeros((count, DIM, DIM))
    np.add.at(covariances, group, w[:, None, None] * weighted)
    covariances /= weights[:, None, None]
    # the heaviest member of each group decides its tag; its source is the heaviest detected
    # member's when the detected members weigh a target's worth (DETECTED_SHARE): a Gaussian a
    # measurement updated this scan, even where a persisting missed-detection copy is heavier
    order = np.lexsort((-w, group))
    heads = order[np.r_[0, np.flatnonzero(np.diff(group[order])) + 1]]
    detected = mixture.sources >= 0
    detected_weight = np.bincount(group, weights=np.where(detected, w, 0.0), minlength=count)
    by_detected = np.lexsort((-np.where(detected, w, -1.0), group))
    best = by_detected[np.r_[0, np.flatnonzero(np.diff(group[by_detected])) + 1]]
    sources = np.where(
        detected_weight >= DETECTED_SHARE, mixture.sources[best], mixture.sources[heads]
    )
    return Mixture(weights, means, covariances, mixture.tags[heads], sources)


def warm_up() -> None:
    """Compile (or load from numba's cache) the merge kernel now, not on a replay's first scans."""
    merge(Mixture.of(np.ones(2), np.zeros((2, DIM)), np.tile(np.eye(DIM), (2, 1, 1))), 4.0)


def prune(mixture: Mixture, threshold: float, max_components: int) -> Mixture:
    """Drop components lighter than `threshold`; keep at most the `max_components` heaviest."""
    keep = np.flatnonzero(mixture.weights >= threshold)
    if len(keep) > max_components:
        keep = keep[np.argsort(-mixture.weights[keep], kind="stable")[:max_components]]
        keep.sort()
    return mixture if len(keep) == len(mixture) else mixture.subset(keep)


@dataclass(frozen=True, eq=False)
class Estimates:
    """Extracted target states: means (N, 4), covariances (N, 4, 4), the weight of the component
    each came from (N,), its tag and its source measurement (-1: none)."""

    means: np.ndarray
    covariances: np.ndarray
    weights: np.ndarray
    tags: np.ndarray
    sources: np.ndarray

    def __len__(self) -> int:
        return len(self.means)


def extract(mixture: Mixture, threshold: float = 0.5) -> Estimates:
    """Vo & Ma's state extraction: round(w) copies of every component with w > threshold."""
    chosen = np.flatnonzero(mixture.weights > threshold)
    copies = np.maximum(np.round(mixture.weights[chosen]).astype(np.int64), 1)
    index = np.repeat(chosen, copies)
    return Estimates(
        mixture.means[index],
        mixture.covariances[index],
        mixture.weights[index],
        mixture.tags[index],
        mixture.sources[index],
    )


@dataclass(frozen=True, eq=False)
class DetectionTerms:
    """Per component (J,): its detection probability, the factor of its missed-detection term,
    and whether it is guarded: not updated by the measurement any visible target -- an unguarded
    component heavier than 0.5 -- explains best (an occluded target's Gaussian must not claim the
    blob of the target that hides it, only a measurement that appears beside it), and by one
    measurement at most, its likeliest."""

    detection: np.ndarray
    miss: np.ndarray
    guarded: np.ndarray

    @classmethod
    def standard(cls, count: int, detection: float) -> DetectionTerms:
        """Vo & Ma's: p_D and 1 - p_D for every component, none guarded."""
        return cls(
            np.full(count, detection), np.full(count, 1.0 - detection), np.zeros(count, bool)
        )


def _taken(numerators: np.ndarray, weights: np.ndarray, guarded: np.ndarray) -> np.ndarray:
    """(M,) the measurements a visible target takes: for every unguarded component heavy enough
    to be one (weight > 0.5), the measurement it explains best."""
    taken = np.zeros(numerators.shape[1], dtype=bool)
    visible = np.flatnonzero(~guarded & (weights > 0.5))
    if len(visible):
        best = np.argmax(numerators[visible], axis=1)
        taken[best[numerators[visible, best] > 0]] = True
    return taken


@dataclass(frozen=True, eq=False)
class UpdateResult:
    """The posterior mixture (pruned) and, per measurement, how much target weight explains it."""

    mixture: Mixture
    explained: np.ndarray  # (M,) sum over components of the detected-term weights


class GmPhdFilter:
    """Vo & Ma's GM-PHD recursion; see the module docstring. `step` = predict, update, reduce."""

    def __init__(self, config: GmPhdConfig, static_birth: Mixture | None = None) -> None:
        if config.problems():
            raise ValueError("invalid GmPhdConfig: " + "; ".join(config.problems()))
        self.config = config
        self.static_birth = static_birth if static_birth is not None else Mixture.empty()
        self.mixture = Mixture.empty()
        self._unexplained = np.zeros((0, AXES))  # last scan's measurements no target explained
        self._birth_pairs = Mixture.empty()  # births made at the last scan, at its time

    def reset(self) -> None:
        self.mixture = Mixture.empty()
        self._unexplained = np.zeros((0, AXES))
        self._birth_pairs = Mixture.empty()

    def _propagate(self, mixture: Mixture, dt: float, noise: np.ndarray) -> Mixture:
        transition = CONSTANT_VELOCITY.transition(dt)
        return Mixture(
            mixture.weights,
            mixture.means @ transition.T,
            transition @ mixture.covariances @ transition.T + noise,
            mixture.tags,
            np.full(len(mixture), -1, np.int64),
        )

    def predict(
        self, dt: float, injected: Mixture | None = None, births: Mixture | None = None
    ) -> Mixture:
        """The predicted intensity dt later: survivors, spawns, `injected` components (e.g.
        occluded targets kept alive), and births -- the measurement-driven ones, the static
        mixture and `births` -- all moved by the motion model. Births are marked (source BIRTH)
        until the update."""
        c = self.config
        noise = CONSTANT_VELOCITY.process_noise(dt, c.process_noise)
        survivors = self._propagate(self.mixture, dt, noise)
        survivors = Mixture(
            c.survival * survivors.weights,
            survivors.means,
            survivors.covariances,
            survivors.tags,
            survivors.sources,
        )
        parts = [survivors]
        if c.spawn_weight > 0 and len(self.mixture):
            spread = np.diag([0.0, 0.0, c.spawn_noise**2, c.spawn_noise**2])
            spawned = self._propagate(self.mixture, dt, noise + spread)
            parts.append(
                Mixture(
                    c.spawn_weight * self.mixture.weights,
                    spawned.means,
                    spawned.covariances,
                    np.zeros(len(spawned), np.int64),
                    spawned.sources,
                )
            )
        if injected is not None and len(injected):
            parts.append(self._propagate(injected, dt, noise))
        for born in (self._birth_pairs, self.static_birth, births):
            if born is not None and len(born):
                moved = self._propagate(born, dt, noise)
                parts.append(replace(moved, sources=np.full(len(moved), BIRTH, np.int64)))
        return Mixture.concatenate(parts)

    def update(
        self, predicted: Mixture, measurements: np.ndarray, terms: DetectionTerms | None = None
    ) -> UpdateResult:
        """Vo & Ma's update of `predicted` with the scan's measurements (M, 2), pruned at T while
        it is built; `terms` changes p_D and the missed-detection factor per component."""
        c = self.config
        z = np.asarray(measurements, dtype=float).reshape(-1, AXES)
        count = len(predicted)
        if terms is None:
            terms = DetectionTerms.standard(count, c.detection)
        # a birth no measurement supports is no target: its missed-detection copy is dropped
        # (a wide birth Gaussian's copy would otherwise merge into nearby targets and widen them)
        missed = Mixture(
            np.where(predicted.sources == BIRTH, 0.0, terms.miss * predicted.weights),
            predicted.means,
            predicted.covariances,
            predicted.tags,
            np.full(count, -1, np.int64),
        )
        if not len(z) or not count:
            return UpdateResult(prune(missed, c.prune_threshold, 1 << 62), np.zeros(len(z)))
        p = predicted.covariances
        innovation_cov = p[:, :AXES, :AXES] + c.measurement_noise**2 * np.eye(AXES)
        likelihood, innovations = gaussian_likelihoods(predicted.means, innovation_cov, z, c.gate)
        numerators = (terms.detection * predicted.weights)[:, None] * likelihood
        if terms.guarded.any():
            guarded = numerators[terms.guarded] * ~_taken(
                numerators, predicted.weights, terms.guarded
            )
            # a hidden target comes back as one measurement: its best, not a spray over several
            best = np.argmax(guarded, axis=1)
            kept = np.zeros_like(guarded)
            kept[np.arange(len(best)), best] = guarded[np.arange(len(best)), best]
            numerators[terms.guarded] = kept
        weights = numerators / (c.clutter_density + numerators.sum(axis=0))[None, :]
        gain = p[:, :, :AXES] @ np.linalg.inv(innovation_cov)  # (J, 4, 2)
        posterior = p - gain @ p[:, :AXES, :]
        rows, cols = np.nonzero(weights >= c.prune_threshold)
        detected = Mixture(
            weights[rows, cols],
            predicted.means[rows] + np.einsum("nij,nj->ni", gain[rows], innovations[rows, cols]),
            posterior[rows],
            predicted.tags[rows],
            cols.astype(np.int64),
        )
        return UpdateResult(
            Mixture.concatenate([prune(missed, c.prune_threshold, 1 << 62), detected]),
            weights.sum(axis=0),
        )

    def _births_from(self, measurements: np.ndarray, explained: np.ndarray, dt: float) -> None:
        """Pair this scan's unexplained measurements with the last scan's: the births of the next
        prediction, at this scan's time."""
        c = self.config
        fresh = measurements[explained < c.birth_gate]
        previous, self._unexplained = self._unexplained, fresh
        if not len(fresh) or not len(previous) or dt <= 0 or c.birth_weight <= 0:
            self._birth_pairs = Mixture.empty()
            return
        step = fresh[:, None, :] - previous[None, :, :]
        new, old = np.nonzero(np.hypot(step[..., 0], step[..., 1]) <= c.max_birth_speed * dt)
        if not len(new):
            self._birth_pairs = Mixture.empty()
            return
        per_measurement = np.bincount(new, minlength=len(fresh))[new]
        means = np.column_stack([fresh[new], step[new, old] / dt])
        r2 = c.measurement_noise**2
        covariance = np.diag([r2, r2, 2 * r2 / dt**2, 2 * r2 / dt**2])
        self._birth_pairs = Mixture.of(
            c.birth_weight / per_measurement, means, np.broadcast_to(covariance, (len(new), 4, 4))
        )

    def reduce(self, mixture: Mixture) -> Mixture:
        c = self.config
        merged = merge(prune(mixture, c.prune_threshold, 1 << 62), c.merge_threshold)
        if c.cap_merged_weight:
            merged = replace(merged, weights=np.minimum(merged.weights, 1.0))
        return prune(merged, c.prune_threshold, c.max_components)

    def step(
        self,
        measurements: np.ndarray,
        dt: float,
        injected: Mixture | None = None,
        terms: Callable[[Mixture], DetectionTerms] | None = None,
        threshold: float | None = None,
        births: Mixture | None = None,
    ) -> Estimates:
        """One scan `dt` after the last: predict (with `injected`), update (with the detection
        terms `terms(predicted)` gives, when given), reduce; returns the states extracted at
        `threshold` (default: the configured extract_threshold)."""
        z = np.asarray(measurements, dtype=float).reshape(-1, AXES)
        predicted = self.predict(dt, injected, births)
        result = self.update(predicted, z, terms(predicted) if terms is not None else None)
        self._births_from(z, result.explained, dt)
        self.mixture = self.reduce(result.mixture)
        return extract(
            self.mixture, self.config.extract_threshold if threshold is None else threshold
        )
