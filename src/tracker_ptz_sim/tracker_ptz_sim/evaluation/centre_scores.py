"""Seed 004's scores on box centres (no rclpy): OSPA and CLEAR MOT with a centre-distance match.

IoU >= 0.5 (MOTChallenge, `metrics`) is harsh on 10-30 px objects: a 3 px offset of a 12 px box
already halves its IoU. Seed 004 scores small objects on points instead, the centres of the
ground-truth and the tracks' boxes (`evaluation.set_metrics`):
- OSPA (p = 2) with the cut-offs c = 5 px and c = 10 px the thesis uses on video, mean over frames;
- MOTA, MOTP (root mean square matched distance, px), IDF1 and identity switches with a match within
  `match_distance` (10 px, about half a mover's size), recall (ReR) and false-alarm rate (FAR);
- MOR, the missed-occlusion rate: an occlusion is a gap in a mover's counted frames (it was
  hidden or barely visible, conf 0, and came back); missed when the track matched in the frame
  before it is not matched within `reacquire` frames after it.

Hidden ground truth: gt.txt rows with conf 0 (a mover hidden behind an occluder or a nearer one, or
less than `min_visibility` visible) are ignored as MOTChallenge ignores its distractors, in every
score here: such a mover is neither a miss nor a target, and a track whose centre lies within
`match_distance` of its centre (and of no counted mover's) is left out of the frame's estimates, so
a track coasting through an occlusion is not a false alarm either. Whether it keeps its identity
shows in IDF1, the identity switches and MOR.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from tracker_ptz_sim.evaluation.metrics import Boxes
from tracker_ptz_sim.evaluation.set_metrics import Points, as_arrays, ospa, score_points, true_runs

MATCH_DISTANCE = 10.0  # px: a track matches a mover whose box centre is this close
OSPA_CUTOFFS = (5.0, 10.0)  # px, the thesis's cut-offs on video (p = 2)
REACQUIRE = 3  # frames after an occlusion within which the track before it must be back


def centres(boxes: Boxes, frames: list[int]) -> list[Points]:
    """Per frame of `frames`, id -> box centre."""
    return [
        {i: np.array(b.center, dtype=float) for i, b in boxes.get(frame, {}).items()}
        for frame in frames
    ]


def without_ignored_points(
    estimates: list[Points], truth: list[Points], ignored: list[Points], match_distance: float
) -> list[Points]:
    """The estimates minus those within `match_distance` of an ignored mover and of no counted
    one (the centre-distance form of `metrics.without_ignored`)."""
    kept = []
    for frame_estimates, counted, skip in zip(estimates, truth, ignored, strict=True):
        kept.append(
            {
                i: e
                for i, e in frame_estimates.items()
                if not _near(e, skip, match_distance) or _near(e, counted, match_distance)
            }
        )
    return kept


def _near(point: np.ndarray, objects: Points, distance: float) -> bool:
    return any(float(np.hypot(*(point - p))) <= distance for p in objects.values())


def occlusion_gaps(truth: list[Points], ignored: list[Points]) -> list[tuple[int, int, int]]:
    """(id, first, last) list indices of every gap in a mover's counted frames during which it
    was ignored (hidden or barely visible) and after which it is counted again."""
    gaps = []
    for mover in sorted({i for frame in truth for i in frame}):
        counted = [mover in frame for frame in truth]
        hidden = [mover in frame and not seen for frame, seen in zip(ignored, counted, strict=True)]
        for first, last in true_runs(hidden):
            if first > 0 and counted[first - 1] and last + 1 < len(truth) and counted[last + 1]:
                gaps.append((mover, first, last))
    return gaps


def centre_scores(
    truth: Boxes,
    ignored: Boxes,
    hypotheses: Boxes,
    frames: list[int],
    match_distance: float = MATCH_DISTANCE,
    cutoffs: tuple[float, ...] = OSPA_CUTOFFS,
    reacquire: int = REACQUIRE,
) -> dict[str, Any]:
    """The module docstring's scores of the tracks' boxes (`hypotheses`) against the counted
    (`truth`) and ignored (conf 0) ground truth over `frames`; OSPA as `ospa_<c>px`."""
    truth_points = centres(truth, frames)
    ignored_points = centres(ignored, frames)
    estimates = without_ignored_points(
        centres(hypotheses, frames), truth_points, ignored_points, match_distance
    )
    gaps = occlusion_gaps(truth_points, ignored_points)
    scores = score_points(truth_points, estimates, match_distance, match_distance, gaps, reacquire)
    result: dict[str, Any] = {
        "match_distance_px": match_distance,
        "mota": scores.mota,
        "motp_px": scores.motp,
        "idf1": scores.idf1,
        "id_switches": scores.id_switches,
        "recall": scores.rer,
        "false_alarm_rate": scores.far,
        "lost_label_rate": scores.mlr,
        "occlusions": scores.occlusions,
        "missed_occlusions": scores.missed_occlusions,
        "missed_occlusion_rate": scores.mor,
        "truth_per_frame": float(np.mean([len(f) for f in truth_points])) if frames else 0.0,
        "estimates_per_frame": float(np.mean([len(f) for f in estimates])) if frames else 0.0,
    }
    for cutoff in cutoffs:
        per_frame = [
            ospa(as_arrays(t)[1], as_arrays(e)[1], cutoff)
            for t, e in zip(truth_points, estimates, strict=True)
        ]
        result[ospa_key(cutoff)] = float(np.mean(per_frame)) if per_frame else 0.0
    return result


def ospa_key(cutoff: float) -> str:
    """The result key of the mean OSPA with cut-off `cutoff` px: 'ospa_5px'."""
    return f"ospa_{cutoff:g}px"
