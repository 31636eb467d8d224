"""Seed 004's labelling of GM-PHD estimates (no rclpy).

The PHD filter extracts unlabelled states; the thesis gives them identities by a Hungarian
assignment (scipy's `linear_sum_assignment`) between the states extracted at k and the labelled
states of k - 1, the cost a Mahalanobis distance. Here the labelled state is first moved by its
velocity to k (x_l^-, the caller's prediction), and the distance uses the estimate's position
covariance plus R plus the track's own extra variance V_l (a track dead-reckoned through an
occlusion is less sure where it is):

    cost = (p_e - x_l^-)^T (P_e,pos + R + V_l I)^-1 (p_e - x_l^-),  gated at `gate`

An estimate from a component tagged with a track's label (an occluded track's own Gaussian)
is barred from the other tracks; of a track's tagged estimates the nearest is its own, the others
are barred. Its cost: its distance, at most `gate_inside` (within the gate however far the guess
drifted); but `gate_inside` for a visible track's guess that no measurement made (its coasting
copy never displaces a detection near it, while a hidden track keeps to its guess and leaves
the blob that hides it to the visible one). The "impulse": for a track inside an
occlusion region, the region is split in four quadrants around the track's last position and
candidates in the quadrant its heading points to cost `impulse` x as much. A hidden track's
hit does not end its occlusion while the point lies within the occlusion radius of another
undetected track of a region (`inside_merged_blob`: not in the thesis).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from tracker_filter.gm_phd.gmphd import Estimates

AXES = 2
BARRED = 1e12


@dataclass(frozen=True, eq=False)
class LabelledStates:
    """The labelled tracks predicted to k: labels (N,), positions (N, 2), velocities (N, 2)
    px/s (the headings of the impulse), their positions' extra variance (N,) px^2, and for each
    the centre of its occlusion region, NaN when it is in none."""

    labels: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    variances: np.ndarray
    occlusion_centres: np.ndarray
    hidden: np.ndarray  # (N,) bool: occluded (not merely beside an occluded one)


def labelling_costs(
    tracks: LabelledStates,
    estimates: Estimates,
    measurement_variance: float,
    impulse: float = 0.5,
    gate_inside: float = 0.0,
) -> np.ndarray:
    """(N tracks, E estimates) assignment costs; see the module docstring."""
    positions = estimates.means[:, :AXES]
    gaps = positions[None, :, :] - tracks.positions[:, None, :]
    cov = estimates.covariances[:, :AXES, :AXES] + measurement_variance * np.eye(AXES)
    extra = tracks.variances[:, None]
    a, b, d = cov[None, :, 0, 0] + extra, cov[None, :, 0, 1], cov[None, :, 1, 1] + extra
    det = a * d - b * b
    gx, gy = gaps[..., 0], gaps[..., 1]
    costs: np.ndarray = (d * gx * gx - 2.0 * b * gx * gy + a * gy * gy) / det
    occluded = np.flatnonzero(np.isfinite(tracks.occlusion_centres[:, 0]))
    for row in occluded:
        heading = tracks.velocities[row]
        if not np.any(heading):
            continue
        side = np.sign(heading)
        offsets = np.sign(positions - tracks.positions[row])
        ahead = ((side == 0) | (offsets == side)).all(axis=1)
        costs[row, ahead] *= impulse
    tagged = np.flatnonzero(estimates.tags > 0)
    if len(tagged):
        own = tracks.labels[:, None] == estimates.tags[None, tagged]
        real = costs[:, tagged]
        guess = (estimates.sources[tagged] < 0)[None, :] & ~tracks.hidden[:, None]
        own_cost = np.where(guess, gate_inside, np.minimum(real, gate_inside))
        costs[:, tagged] = np.where(own, own_cost, BARRED)
        # of an occluded track's estimates only the nearest to where it should be is its own
        for row in np.flatnonzero(own.any(axis=1)):
            mine = np.flatnonzero(own[row])
            nearest = mine[np.argmin(real[row, mine])]
            costs[:, tagged[mine[mine != nearest]]] = BARRED
    return costs


def assign(costs: np.ndarray, gate: float) -> tuple[np.ndarray, np.ndarray]:
    """Hungarian assignment of tracks (rows) to estimates (columns); pairs costing more than
    `gate` are not made. Returns the assigned rows and columns.

    Every pair beyond the gate costs the same before solving: with their true costs the solver
    would trade a good pair for a cheaper sum of two pairs that are both dropped afterwards."""
    if not costs.size:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    rows, cols = linear_sum_assignment(np.where(costs <= gate, costs, BARRED))
    kept = costs[rows, cols] <= gate
    return rows[kept].astype(np.int64), cols[kept].astype(np.int64)


def inside_merged_blob(
    tracks: LabelledStates, hit: np.ndarray, hit_points: np.ndarray, radius: float
) -> np.ndarray:
    """Per track: hidden and hit, at a point (`hit_points`, (N, 2)) within `radius` of where
    another track of an occlusion region that has no hit of its own is placed. That blob is
    still the merged one (several targets meet in it), not the hidden target come out: taken
    as its hit, it ended the occlusion inside the blob, and the track followed the blob off its
    target's line."""
    inside = np.zeros(len(hit), dtype=bool)
    waiting = np.isfinite(tracks.occlusion_centres[:, 0]) & ~hit
    if not waiting.any():
        return inside
    for row in np.flatnonzero(hit & tracks.hidden):
        others = waiting.copy()
        others[row] = False
        gaps = np.hypot(*(tracks.positions[others] - hit_points[row]).T)
        inside[row] = bool((gaps <= radius).any())
    return inside
