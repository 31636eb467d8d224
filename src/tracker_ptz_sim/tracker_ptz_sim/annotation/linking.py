"""Offline linking of per-frame person boxes into tracks, and the finishing of ground truth (no rclpy).

`link`: a forward pass in the manner of ByteTrack: each track predicts its box (its centre moved
on at its recent velocity, its recent median size); the Hungarian assignment on IoU matches
confident boxes first (score >= `high`), then the remaining tracks to the weak boxes (>= `low`),
then the tracks lost for a frame or more to the confident boxes left near their prediction (a
person coming out from behind the sign); a box of another height never matches; only a confident
box starts a track; a track unmatched for more than `max_gap` frames ends. Tracks observed in
fewer than `min_boxes` frames, or never confidently (`min_peak`), are dropped.

`finish`: ground truth from reviewed tracks: gaps of at most `max_gap` frames filled by linear
interpolation (score 0: what the review sheets draw thin), boxes clipped to the frame, and each
box's visibility, the share of it not covered by the boxes of people nearer the camera (a lower
bottom edge).

The tables and their files are `simulation.ground_truth`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from tracker_msgs_py.geometry import corner_iou_matrix
from tracker_ptz_sim.simulation.ground_truth import Box, Detections, Tracks

DETECTION_FLOOR = 0.1  # fused score below which the assistant's boxes are not kept


@dataclass(frozen=True)
class LinkConfig:
    high: float = 0.35  # a box at least this confident may start a track and is matched first
    low: float = DETECTION_FLOOR  # weaker boxes only continue tracks
    match_iou: float = 0.3  # least IoU of a predicted box and a box to match them
    max_size_change: float = 1.5  # a box more than this x taller or shorter is not the track's
    refind_distance: float = 0.6  # of the height: how far from its prediction a lost track ...
    max_gap: int = 15  # ... may be found again within this many frames (1.5 s at 10 fps)
    velocity_frames: int = 5  # the last observations the velocity and size are measured over
    min_boxes: int = 5  # tracks observed in fewer frames are dropped
    min_peak: float = 0.45  # ... and tracks never seen at least this confidently


@dataclass
class _Live:
    ident: int
    observed: dict[int, np.ndarray]  # frame -> corners
    scores: list[float]
    last: int

    def predict(self, frame: int, window: int) -> np.ndarray:
        """The box at `frame`: the centre moved on at its recent velocity, the recent median
        size (a person half behind something shrinks for a few frames; the prediction should
        not follow that onto whatever is left)."""
        frames = sorted(self.observed)[-window:]
        boxes = np.array([self.observed[f] for f in frames])
        centres = (boxes[:, :2] + boxes[:, 2:]) / 2
        size = np.median(boxes[:, 2:] - boxes[:, :2], axis=0)
        centre = centres[-1]
        if len(frames) >= 2:
            centre = centre + (centres[-1] - centres[0]) / (frames[-1] - frames[0]) * (
                frame - frames[-1]
            )
        return np.concatenate([centre - size / 2, centre + size / 2])


def _heights(boxes: np.ndarray) -> np.ndarray:
    heights: np.ndarray = boxes[:, 3] - boxes[:, 1]
    return heights


def _size_fits(predicted: np.ndarray, boxes: np.ndarray, change: float) -> np.ndarray:
    """(N, M): box m's height within `change` x of prediction n's."""
    ratio = _heights(boxes)[None, :] / np.maximum(_heights(predicted)[:, None], 1e-6)
    fits: np.ndarray = (ratio <= change) & (ratio >= 1 / change)
    return fits


def _match(
    predicted: np.ndarray, boxes: np.ndarray, c: LinkConfig, lost: np.ndarray | None = None
) -> list[tuple[int, int]]:
    """Pairs (prediction, box) by the Hungarian assignment on IoU (>= match_iou); with `lost`
    (a flag per prediction), the lost tracks by centre distance instead (<= refind_distance of
    the height). Boxes of another size never pair."""
    if len(predicted) == 0 or len(boxes) == 0:
        return []
    fits = _size_fits(predicted, boxes, c.max_size_change)
    if lost is None:
        score = np.where(fits, corner_iou_matrix(predicted, boxes), 0.0)
        good = score >= c.match_iou
    else:
        centre_p = (predicted[:, None, :2] + predicted[:, None, 2:]) / 2
        centre_b = (boxes[None, :, :2] + boxes[None, :, 2:]) / 2
        distance = np.hypot(*(centre_p - centre_b).transpose(2, 0, 1))
        relative = distance / np.maximum(_heights(predicted)[:, None], 1e-6)
        good = fits & lost[:, None] & (relative <= c.refind_distance)
        score = np.where(good, 1.0 - relative, 0.0)
    rows, cols = linear_sum_assignment(-score)
    return [(int(r), int(k)) for r, k in zip(rows, cols, strict=True) if good[r, k]]


def link(detections: Detections, config: LinkConfig | None = None) -> Tracks:
    """Tracks with ids 1, 2, ... in order of first appearance (see the module docstring)."""
    c = config or LinkConfig()
    live: list[_Live] = []
    ended: list[_Live] = []
    next_id = 1
    for frame in sorted(detections.by_frame):
        found = detections.by_frame[frame]
        corners = np.array([b.corners for b in found]).reshape(-1, 4)
        scores = np.array([b.score for b in found])
        still: list[_Live] = []
        for track in live:
            (ended if frame - track.last > c.max_gap else still).append(track)
        live = still
        unmatched = list(range(len(live)))
        taken: set[int] = set()
        high, low = scores >= c.high, (scores >= c.low) & (scores < c.high)
        for tier, refind in ((high, False), (low, False), (high, True)):
            candidates = [k for k in np.flatnonzero(tier) if int(k) not in taken]
            predicted = np.array([live[t].predict(frame, c.velocity_frames) for t in unmatched])
            lost = np.array([frame - live[t].last > 1 for t in unmatched]) if refind else None
            pairs = _match(predicted.reshape(-1, 4), corners[candidates].reshape(-1, 4), c, lost)
            for r, col in pairs:
                track, box = live[unmatched[r]], int(candidates[col])
                track.observed[frame] = corners[box]
                track.scores.append(float(scores[box]))
                track.last = frame
                taken.add(box)
            matched = {unmatched[r] for r, _ in pairs}
            unmatched = [t for t in unmatched if t not in matched]
        for new in (int(b) for b in np.flatnonzero(high)):
            if new not in taken:
                live.append(_Live(next_id, {frame: corners[new]}, [float(scores[new])], frame))
                next_id += 1
    tracks = Tracks()
    kept = [
        t for t in ended + live if len(t.observed) >= c.min_boxes and max(t.scores) >= c.min_peak
    ]
    for new_id, track in enumerate(sorted(kept, key=lambda t: (min(t.observed), t.ident)), 1):
        score_of = dict(zip(sorted(track.observed), track.scores, strict=True))
        tracks.by_id[new_id] = {
            f: Box.from_corners(box, score_of[f]) for f, box in sorted(track.observed.items())
        }
    return tracks


def interpolate(boxes: dict[int, Box], max_gap: int) -> dict[int, Box]:
    """The boxes with every gap of at most `max_gap` frames filled linearly between its ends."""
    frames = sorted(boxes)
    out = dict(boxes)
    for a, b in zip(frames, frames[1:], strict=False):
        if 1 < b - a <= max_gap + 1:
            start, end = boxes[a].corners, boxes[b].corners
            for f in range(a + 1, b):
                t = (f - a) / (b - a)
                out[f] = Box.from_corners(start + t * (end - start), 0.0)
    return dict(sorted(out.items()))


def clip(box: Box, width: int, height: int) -> Box | None:
    """The part of the box inside the frame (None: nothing of it is)."""
    x0, y0 = max(box.x, 0.0), max(box.y, 0.0)
    x1, y1 = min(box.x + box.w, float(width)), min(box.y + box.h, float(height))
    if x1 - x0 < 1 or y1 - y0 < 1:
        return None
    return Box(x0, y0, x1 - x0, y1 - y0, box.score, box.visibility)


def visibilities(boxes: dict[int, Box]) -> dict[int, float]:
    """Per id, the share of its box not covered by nearer people's boxes (lower bottom edges),
    on a 1 px grid."""
    out = {}
    for i, box in boxes.items():
        x0, y0 = int(np.floor(box.x)), int(np.floor(box.y))
        w, h = max(1, int(np.ceil(box.w))), max(1, int(np.ceil(box.h)))
        covered = np.zeros((h, w), bool)
        for j, other in boxes.items():
            if j == i or other.y + other.h <= box.y + box.h:
                continue
            ox0 = int(np.clip(np.floor(other.x) - x0, 0, w))
            ox1 = int(np.clip(np.ceil(other.x + other.w) - x0, 0, w))
            oy0 = int(np.clip(np.floor(other.y) - y0, 0, h))
            oy1 = int(np.clip(np.ceil(other.y + other.h) - y0, 0, h))
            covered[oy0:oy1, ox0:ox1] = True
        out[i] = round(1.0 - float(covered.mean()), 3)
    return out


def finish(tracks: Tracks, width: int, height: int, max_gap: int = LinkConfig.max_gap) -> Tracks:
    """Ground truth from reviewed tracks (see the module docstring)."""
    filled = Tracks()
    for i, boxes in tracks.by_id.items():
        inside = {}
        for f, box in interpolate(boxes, max_gap).items():
            clipped = clip(box, width, height)
            if clipped is not None:
                inside[f] = clipped
        if inside:
            filled.by_id[i] = inside
    frames = sorted({f for boxes in filled.by_id.values() for f in boxes})
    for f in frames:
        present = filled.in_frame(f)
        for i, v in visibilities(present).items():
            b = present[i]
            filled.by_id[i][f] = Box(b.x, b.y, b.w, b.h, b.score, v)
    return filled
