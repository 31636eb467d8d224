"""Point-set tracking metrics of seed 004: OSPA, CLEAR MOT on points, FAR, ReR, MLR, MOR (no rclpy).

Per frame, ground truth and estimates are labelled points: `Points = dict[int, np.ndarray]` maps
an id to its (2,) position (or (3,): every point of a run has the same dimension).

- OSPA (Schuhmacher et al. 2008), order p and cut-off c, for sets X (m points) and Y (n), m <= n:
  d_p^(c)(X, Y) = ((1/n) [min_pi sum_{i<=m} d^(c)(x_i, y_pi(i))^p + c^p (n - m)])^(1/p),
  d^(c) = min(c, ||x - y||); 0 for two empty sets, c when only one is empty.
- CLEAR MOT (Bernardin & Stiefelhagen 2008) by motmetrics with a Euclidean match threshold:
  MOTA = 1 - sum(misses + false positives + mismatches) / sum(ground truth), MOTP, IDF1.
- The thesis's rates, from the same matching: FAR = false estimates / estimates; ReR = correct
  estimates / true targets; MLR = lost-label time / target time, a target's label being the
  estimate id it was matched with most and its lost-label time the frames it is not matched with
  that id; MOR = missed occlusions / occlusions, an occlusion missed when the id last matched within
  `reacquire` frames before it is not among those matched within `reacquire` frames after it.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import motmetrics
import numpy as np
from scipy.optimize import linear_sum_assignment

Points = dict[int, np.ndarray]


def ospa(truth: np.ndarray, estimates: np.ndarray, cutoff: float, order: float = 2.0) -> float:
    """OSPA distance between point sets (m, d) and (n, d)."""
    x = np.asarray(truth, dtype=float).reshape(len(truth), -1) if len(truth) else np.zeros((0, 2))
    y = np.asarray(estimates, dtype=float).reshape(len(estimates), -1) if len(estimates) else x[:0]
    if len(x) > len(y):
        x, y = y, x
    m, n = len(x), len(y)
    if n == 0:
        return 0.0
    if m == 0:
        return float(cutoff)
    distances = np.minimum(np.linalg.norm(x[:, None, :] - y[None, :, :], axis=2), cutoff) ** order
    rows, cols = linear_sum_assignment(distances)
    total = distances[rows, cols].sum() + cutoff**order * (n - m)
    return float((total / n) ** (1.0 / order))


def as_arrays(points: Points, dim: int = 2) -> tuple[list[int], np.ndarray]:
    """The ids in order and their points (N, dim)."""
    ids = sorted(points)
    return ids, np.array([points[i] for i in ids], dtype=float).reshape(len(ids), dim)


def true_runs(flags: Sequence[bool] | np.ndarray) -> list[tuple[int, int]]:
    """(first, last) index of every run of consecutive True values in `flags`."""
    edges = np.diff(np.r_[0, np.asarray(flags, dtype=np.int8), 0])
    firsts = np.flatnonzero(edges == 1)
    lasts = np.flatnonzero(edges == -1) - 1
    return list(zip(firsts.tolist(), lasts.tolist(), strict=True))


@dataclass(frozen=True)
class PointScores:
    mota: float
    motp: float  # mean distance of matches
    idf1: float
    id_switches: int
    far: float
    rer: float
    mlr: float
    mor: float  # NaN when there was no occlusion
    occlusions: int
    missed_occlusions: int
    ospa: float  # mean over frames
    frames: int
    objects: int = 0  # true targets summed over frames (CLEAR MOT's sum of g)
    misses: int = 0
    false_positives: int = 0


def score_points(
    truth: list[Points],
    estimates: list[Points],
    match_distance: float,
    ospa_cutoff: float,
    occlusions: list[tuple[int, int, int]] | None = None,
    reacquire: int = 3,
) -> PointScores:
    """Every metric of the module docstring over aligned frame lists. `occlusions` are
    (true id, first frame, last frame) of each occlusion, frames as list indices."""
    accumulator = motmetrics.MOTAccumulator(auto_id=True)
    ospas = []
    dim = next((len(p) for f in truth + estimates for p in f.values()), 2)  # 2-D or 3-D points
    for frame_truth, frame_estimates in zip(truth, estimates, strict=True):
        t_ids, t_points = as_arrays(frame_truth, dim)
        e_ids, e_points = as_arrays(frame_estimates, dim)
        squared = motmetrics.distances.norm2squared_matrix(
            t_points, e_points, max_d2=match_distance**2
        )
        accumulator.update(t_ids, e_ids, squared)
        ospas.append(ospa(t_points, e_points, ospa_cutoff))
    names = ["mota", "motp", "idf1", "num_switches", "num_frames", "num_objects", "num_misses"]
    names.append("num_false_positives")
    row = motmetrics.metrics.create().compute(accumulator, metrics=names).iloc[0]
    matching = _matching(accumulator, len(truth))
    target_frames = sum(len(f) for f in truth)
    estimate_count = sum(len(f) for f in estimates)
    correct = sum(len(m) for m in matching)
    missed = _missed_occlusions(matching, occlusions or [], reacquire)
    return PointScores(
        mota=float(row["mota"]),
        motp=float(np.sqrt(row["motp"])) if np.isfinite(row["motp"]) else float("nan"),
        idf1=float(row["idf1"]),
        id_switches=int(row["num_switches"]),
        far=(estimate_count - correct) / estimate_count if estimate_count else 0.0,
        rer=correct / target_frames if target_frames else 1.0,
        mlr=_lost_label_rate(matching, truth),
        mor=missed / len(occlusions) if occlusions else float("nan"),
        occlusions=len(occlusions or []),
        missed_occlusions=missed,
        ospa=float(np.mean(ospas)) if ospas else 0.0,
        frames=int(row["num_frames"]),
        objects=int(row["num_objects"]),
        misses=int(row["num_misses"]),
        false_positives=int(row["num_false_positives"]),
    )


def _matching(accumulator: motmetrics.MOTAccumulator, frames: int) -> list[dict[int, int]]:
    matches: list[dict[int, int]] = [{} for _ in range(frames)]
    events = accumulator.mot_events
    for (frame, _), event in events.iterrows():
        if event["Type"] in ("MATCH", "SWITCH"):
            matches[int(frame)][int(event["OId"])] = int(event["HId"])
    return matches


def _lost_label_rate(matches: list[dict[int, int]], truth: list[Points]) -> float:
    present = Counter(i for frame in truth for i in frame)
    if not present:
        return 0.0
    labels = {
        target: Counter(m[target] for m in matches if target in m).most_common(1)
        for target in present
    }
    kept = sum(
        1
        for m in matches
        for target, estimate in m.items()
        if labels[target] and labels[target][0][0] == estimate
    )
    return 1.0 - kept / sum(present.values())


def _missed_occlusions(
    matches: list[dict[int, int]], occlusions: list[tuple[int, int, int]], reacquire: int
) -> int:
    missed = 0
    for target, first, last in occlusions:
        before = [matches[k].get(target) for k in range(max(0, first - reacquire), first)]
        known = [label for label in before if label is not None]
        after = [
            matches[k].get(target) for k in range(last + 1, min(last + 1 + reacquire, len(matches)))
        ]
        if not known or known[-1] not in after:
            missed += 1
    return missed
