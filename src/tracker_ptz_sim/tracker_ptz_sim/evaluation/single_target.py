"""Single-target accuracy as seed 003 measures it (no rclpy), for trackers started on a rectangle,
and the loops that run them over recorded frames: seed 001's CamShift, alone or with a filter's
prediction placing each search window (`follow`), and seed 003's colour particle filter
(`follow_particles`).

- Q1 ("quality"): IoU of the estimated and the true box per frame, averaged over the frames the
  target is in the ground truth (a frame without an estimate scores 0);
- Q2 ("precision"): share of those frames whose estimated centre lies inside the square centred on
  the true box with side 0.8 x the box's shorter side;
- success: share of frames with IoU >= 0.5 (the threshold the multi-target scores use).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from tracker_detect.camshift import CamShiftConfig, CamShiftTracker
from tracker_detect.detector import CameraFrame
from tracker_filter.colour_particle import Appearance, ColourParticleFilter, ParticleFilterConfig
from tracker_filter.filters import FilterFactory
from tracker_msgs_py.codec import NS_PER_S
from tracker_msgs_py.geometry import Rect

CENTRE_SQUARE = 0.8  # Q2's square side, times the true box's shorter side
SUCCESS_IOU = 0.5


@dataclass(frozen=True)
class SingleTargetScores:
    frames: int  # frames with a true box
    mean_iou: float  # Q1
    centre_in_box: float  # Q2
    success: float  # share of frames with IoU >= SUCCESS_IOU
    missed: int  # frames with a true box and no estimate


def centre_inside(estimate: Rect, truth: Rect, side_factor: float = CENTRE_SQUARE) -> bool:
    """True when the estimate's centre lies in the square of side side_factor x min(w, h) centred
    on the true box."""
    half = side_factor * min(truth.width, truth.height) / 2.0
    (ex, ey), (tx, ty) = estimate.center, truth.center
    return abs(ex - tx) <= half and abs(ey - ty) <= half


def score_single_target(
    truth: Mapping[int, Rect], estimates: Mapping[int, Rect | None]
) -> SingleTargetScores:
    """Scores over the frames of `truth`; `estimates` may lack frames or hold None (a miss)."""
    ious, inside, missed = [], 0, 0
    for frame, box in truth.items():
        estimate = estimates.get(frame)
        if estimate is None:
            ious.append(0.0)
            missed += 1
            continue
        ious.append(box.iou(estimate))
        inside += centre_inside(estimate, box)
    n = len(ious)
    if n == 0:
        return SingleTargetScores(0, 0.0, 0.0, 0.0, 0)
    return SingleTargetScores(
        n, sum(ious) / n, inside / n, sum(i >= SUCCESS_IOU for i in ious) / n, missed
    )


def pooled(scores: list[SingleTargetScores]) -> SingleTargetScores:
    """Frame-weighted totals of several runs."""
    frames = sum(s.frames for s in scores)
    if frames == 0:
        return SingleTargetScores(0, 0.0, 0.0, 0.0, 0)

    def weighted(name: str) -> float:
        return sum(getattr(s, name) * s.frames for s in scores) / frames

    return SingleTargetScores(
        frames,
        weighted("mean_iou"),
        weighted("centre_in_box"),
        weighted("success"),
        sum(s.missed for s in scores),
    )


def follow(
    frames: np.ndarray | Sequence[np.ndarray],  # (N, H, W, 3) or N images
    stamps_ns: Sequence[int],
    start: int,
    region: Rect,
    last: int,
    predictor: FilterFactory | None = None,
    config: CamShiftConfig | None = None,
) -> dict[int, Rect | None]:
    """CamShift started on `region` of frame `start`, run over frames start+1..last of a static
    camera (image = scene); with a `predictor`, each search window is centred on the filter's
    one-step prediction and each CamShift centre updates it (a miss leaves the prediction).
    Returns the box per frame, None where CamShift missed."""
    tracker = CamShiftTracker(config)
    reason = tracker.select_region(region, CameraFrame(stamps_ns[start], frames[start]))
    if reason is not None:
        raise ValueError(f"cannot start on {region}: {reason}")
    state = None
    if predictor is not None:
        state = predictor.new_filter(np.array(region.center), stamps_ns[start] / NS_PER_S)
    boxes: dict[int, Rect | None] = {}
    for k in range(start + 1, last + 1):
        if state is not None:
            state.predict(stamps_ns[k] / NS_PER_S)
            tracker.guide((float(state.mean[0]), float(state.mean[1])))
        blobs = tracker.process(CameraFrame(stamps_ns[k], frames[k])).blobs
        boxes[k] = blobs[0].bbox if blobs else None
        if state is not None and blobs:
            state.update(np.array([blobs[0].centroid_x, blobs[0].centroid_y]))
    return boxes


def follow_particles(
    frames: np.ndarray | Sequence[np.ndarray],
    start: int,
    region: Rect,
    last: int,
    appearance: Appearance,
    config: ParticleFilterConfig,
    seed: int,
) -> dict[int, Rect | None]:
    """Seed 003's particle filter started on `region` of frame `start` (its reference), run over
    frames start+1..last of a static camera; the estimate's box per frame."""
    start_box = np.array([region.x, region.y, region.width, region.height])
    rng = np.random.default_rng(seed)
    tracker = ColourParticleFilter(frames[start], start_box, appearance, config, rng)
    boxes: dict[int, Rect | None] = {}
    for k in range(start + 1, last + 1):
        x, y, w, h = (float(v) for v in tracker.step(frames[k]).box)
        boxes[k] = Rect(x, y, w, h)
    return boxes
