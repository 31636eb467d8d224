"""Single-target accuracy as seed 003 measures it (no rclpy), for trackers started on a rectangle,
and the loops that run them over recorded frames: seed 001's CamShift, alone or with a filter's
prediction placing each search window (`follow`), and seed 003's colour particle filter
(`follow_particles`).

- Q1 ("quality"): IoU of the estimated and the true box per frame, averaged over the frames the
  target is in the ground truth (a frame without an estimate scores 0);
- Q2 ("precision"): share of those frames whose estimated centre lies inside the square centred on
  the true box with side 0.8 x the box's shorter side;
- success: share of frames with IoU >= 0.5 (the threshold the multi-target scores use);
- kept through occlusion: after every stretch of frames where the target is hidden, whether the
  estimate's centre is back in Q2's square in most of the frames that follow.

A moving camera (`operator_path`, `WindowedFrames`) is a window over the recorded scene aimed,
with a lag and some sway, at the target as a camera operator would; the trackers see the window.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from tracker_detect.camshift.camshift import CamShiftConfig, CamShiftTracker
from tracker_detect.detector import CameraFrame
from tracker_filter.filters import FilterFactory
from tracker_filter.object_scale import ExpectedHeight
from tracker_filter.particles.colour_particle import (
    Appearance,
    ColourParticleFilter,
    ImageView,
    ParticleFilterConfig,
)
from tracker_filter.particles.foreground_cue import ForegroundMask
from tracker_msgs_py.codec import NS_PER_S
from tracker_msgs_py.geometry import Rect

CENTRE_SQUARE = 0.8  # Q2's square side, times the true box's shorter side
SUCCESS_IOU = 0.5
MIN_GAP = 5  # frames: a shorter stretch without a scored box is not an occlusion
AFTER_GAP = 20  # frames scored after an occlusion to decide whether the target was kept


@dataclass(frozen=True)
class SingleTargetScores:
    frames: int  # frames with a true box
    mean_iou: float  # Q1
    centre_in_box: float  # Q2
    success: float  # share of frames with IoU >= SUCCESS_IOU
    missed: int  # frames with a true box and no estimate
    # Q1's two errors apart (a miss scores 0 in both): the mean IoU of a box of the true size
    # at the estimate's centre (what the centre costs), of the estimate's size at the true
    # centre (what the size costs)
    iou_true_size: float = 0.0
    iou_true_centre: float = 0.0


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
    ious, inside, missed, true_size, true_centre = [], 0, 0, 0.0, 0.0
    for frame, box in truth.items():
        estimate = estimates.get(frame)
        if estimate is None:
            ious.append(0.0)
            missed += 1
            continue
        ious.append(box.iou(estimate))
        inside += centre_inside(estimate, box)
        true_size += box.iou(Rect.from_center(*estimate.center, box.width, box.height))
        true_centre += box.iou(Rect.from_center(*box.center, estimate.width, estimate.height))
    n = len(ious)
    if n == 0:
        return SingleTargetScores(0, 0.0, 0.0, 0.0, 0)
    success = sum(i >= SUCCESS_IOU for i in ious) / n
    return SingleTargetScores(
        n, sum(ious) / n, inside / n, success, missed, true_size / n, true_centre / n
    )


def pooled(scores: list[SingleTargetScores]) -> SingleTargetScores:
    """Frame-weighted totals of several runs."""
    frames = sum(s.frames for s in scores)
    if frames == 0:
        return SingleTargetScores(0, 0.0, 0.0, 0.0, 0)

    def weighted(name: str) -> float:
        mean: float = sum(getattr(s, name) * s.frames for s in scores) / frames
        return mean

    return SingleTargetScores(
        frames,
        weighted("mean_iou"),
        weighted("centre_in_box"),
        weighted("success"),
        sum(s.missed for s in scores),
        weighted("iou_true_size"),
        weighted("iou_true_centre"),
    )


def kept_through_gaps(
    truth: Mapping[int, Rect],
    estimates: Mapping[int, Rect | None],
    min_gap: int = MIN_GAP,
    after: int = AFTER_GAP,
) -> list[bool]:
    """For every stretch of at least `min_gap` frames without a true box between two frames with
    one: whether the estimate's centre is in Q2's square in more than half of the next `after`
    frames with a true box."""
    frames = sorted(truth)
    kept = []
    for i in range(1, len(frames)):
        if frames[i] - frames[i - 1] - 1 < min_gap:
            continue
        following = frames[i : i + after]
        inside = 0
        for k in following:
            estimate = estimates.get(k)
            inside += estimate is not None and centre_inside(estimate, truth[k])
        kept.append(inside > len(following) / 2)
    return kept


@dataclass(frozen=True)
class CameraPath:
    """A camera window of `size` (w, h) px over the scene: its top-left corner in each frame."""

    size: tuple[int, int]
    origins: Mapping[int, tuple[int, int]]

    def to_view(self, frame: int, box: Rect) -> Rect | None:
        """`box` (scene px) in the window of `frame`, clipped to it; None when outside."""
        x, y = self.origins[frame]
        w, h = self.size
        shifted = Rect(box.x - x, box.y - y, box.width, box.height)
        return shifted.intersection(Rect(0.0, 0.0, float(w), float(h)))


def operator_path(
    truth: Mapping[int, Rect],
    frames: range,
    scene_size: tuple[int, int],
    size: tuple[int, int],
    fps: float,
    lag_s: float = 0.7,
    sway_px: float = 12.0,
    sway_period_s: float = 3.0,
) -> CameraPath:
    """A hand-held camera kept on the target: the window's centre follows the true box's centre
    (interpolated through the frames where it is hidden) with a first-order lag of `lag_s`, plus a
    sinusoidal sway, clamped to the scene."""
    known = sorted(k for k in truth if k in frames)
    if not known:
        raise ValueError("the target has no true box in these frames")
    centres = np.array([truth[k].center for k in known])
    xs = np.interp(list(frames), known, centres[:, 0])
    ys = np.interp(list(frames), known, centres[:, 1])
    gain = 1.0 - math.exp(-1.0 / (fps * lag_s))
    (width, height), (w, h) = scene_size, size
    cx, cy = xs[0], ys[0]
    origins = {}
    for i, k in enumerate(frames):
        cx += gain * (xs[i] - cx)
        cy += gain * (ys[i] - cy)
        sway = sway_px * math.sin(2 * math.pi * i / (fps * sway_period_s))
        x = int(np.clip(round(cx + sway - w / 2), 0, width - w))
        y = int(np.clip(round(cy - h / 2), 0, height - h))
        origins[k] = (x, y)
    return CameraPath(size, origins)


class WindowedFrames(Sequence[np.ndarray]):
    """The frames a camera following `path` sees: frame k cropped to its window (views, no copy)."""

    def __init__(self, frames: np.ndarray | Sequence[np.ndarray], path: CameraPath) -> None:
        self._frames, self._path = frames, path

    def __len__(self) -> int:
        return len(self._frames)

    def __getitem__(self, k: int) -> np.ndarray:  # type: ignore[override]  # no slices
        x, y = self._path.origins[k]
        w, h = self._path.size
        return self._frames[k][y : y + h, x : x + w]


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


@dataclass(frozen=True)
class GroundLines:
    """The ground line (`object_scale.HeightByRow.line`: a person's height against the row of
    their feet, scene px) and a person's usual aspect (`HeightByRow.aspect`) as the suite's
    tracker had learned them by each frame (None before its first fit; no aspects: none known),
    and the row of the scene each frame's image starts at (0: the whole scene)."""

    lines: Sequence[tuple[float, float] | None]
    top_rows: Mapping[int, float] | None = None
    aspects: Sequence[float | None] | None = None

    def expected(self, frame: int, reference: np.ndarray, seen: int) -> ExpectedHeight | None:
        """The height of the object of the box `reference` (image px of frame `seen`) where a box
        stands in frame `frame`'s image, from the line learned by `frame`."""
        line = self.lines[frame]
        if line is None:
            return None
        rows = self.top_rows
        through = ExpectedHeight.through(line, reference, 0.0 if rows is None else rows[seen])
        if through is None:
            return None
        if self.aspects is not None:
            through = through.with_aspect(self.aspects[frame])
        return through if rows is None else through.shifted(rows[frame])


def follow_particles(
    frames: np.ndarray | Sequence[np.ndarray],
    start: int,
    region: Rect,
    last: int,
    appearance: Appearance,
    config: ParticleFilterConfig,
    seed: int,
    masks: Sequence[np.ndarray] | None = None,
    ground: GroundLines | None = None,
    origins: Mapping[int, tuple[int, int]] | None = None,
) -> dict[int, Rect | None]:
    """Seed 003's particle filter started on `region` of frame `start` (its reference), run over
    frames start+1..last, given the motion detector's foreground `masks` (per frame, for the
    foreground cue) and the `ground` lines learned so far (for the height prior) when there
    are; the estimate's box per frame in the frame's image, clipped to it (the truth is the
    visible box). Without `origins` the camera is static and the filter works in image px; with
    them, frame k's image is the window whose top-left corner is at origins[k] (scene px), a pose
    the filter is told, so it works in scene px as it does in the graph."""
    start_box = np.array([region.x, region.y, region.width, region.height])
    rng = np.random.default_rng(seed)
    if origins is not None:
        start_box = start_box + [*origins[start], 0.0, 0.0]
        ground = None if ground is None else replace(ground, top_rows=None)  # scene rows
    tracker = ColourParticleFilter(
        frames[start], start_box, appearance, config, rng, view=_view(origins, start)
    )
    boxes: dict[int, Rect | None] = {}
    for k in range(start + 1, last + 1):
        image = frames[k]
        foreground = None if masks is None else ForegroundMask.of(masks[k])
        height = None if ground is None else ground.expected(k, start_box, start)
        view = _view(origins, k)
        estimate = tracker.step(image, view=view, foreground=foreground, height=height)
        frame = Rect(0.0, 0.0, float(image.shape[1]), float(image.shape[0]))
        x, y, w, h = (float(v) for v in view.to_image(estimate.box[None])[0])
        boxes[k] = Rect(x, y, w, h).intersection(frame)
    return boxes


def _view(origins: Mapping[int, tuple[int, int]] | None, frame: int) -> ImageView:
    """Where frame `frame`'s image lies in the scene (the identity for a static camera)."""
    if origins is None:
        return ImageView()
    x, y = origins[frame]
    return ImageView((float(x), float(y)))
