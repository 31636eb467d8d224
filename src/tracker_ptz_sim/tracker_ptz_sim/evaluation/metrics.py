"""Accuracy of a run against ground truth (no rclpy): CLEAR MOT and IDF1 through motmetrics, HOTA
through trackeval (both at MOTChallenge's IoU >= 0.5 matching), and the pan-tilt figures (how often
the followed target is inside the view, how well it is centred).

Boxes are MOTChallenge rows: frame (1-based), id, x, y, width, height in scene pixels.
"""

from __future__ import annotations

import contextlib
import io
from collections import Counter
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import motmetrics
import numpy as np

with contextlib.redirect_stdout(io.StringIO()):  # it prints which optional datasets it cannot load
    from trackeval.metrics import HOTA

from tracker_msgs_py.geometry import Rect, iou_matrix
from tracker_msgs_py.labels import MOTION, mot_class_id

Boxes = dict[int, dict[int, Rect]]  # frame -> id -> box


def load_mot(path: Path, ignored: bool = False) -> Boxes:
    """A MOTChallenge file (gt.txt or a tracker's output) as boxes per frame. Rows of a gt.txt with
    conf 0 (MOTChallenge's "ignore": e.g. a person almost fully hidden) are left out, or, with
    `ignored`, are the only ones returned."""
    boxes: Boxes = {}
    text = path.read_text().strip()
    if not text:
        return boxes
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.split(",")
        if len(fields) < 6:
            raise ValueError(f"{path}:{number}: expected at least 6 comma-separated fields")
        frame, object_id = int(float(fields[0])), int(float(fields[1]))
        is_ignored = len(fields) > 6 and float(fields[6]) == 0.0 and path.name == "gt.txt"
        if is_ignored != ignored:
            continue
        x, y, w, h = (float(v) for v in fields[2:6])
        boxes.setdefault(frame, {})[object_id] = Rect(x, y, w, h)
    return boxes


def mot_row(
    frame: int, track_id: int, box: Rect, confidence: float = 1.0, label: str = MOTION
) -> str:
    """One MOTChallenge result row (frame from 1, box in scene px), the reader of `load_mot`:
    `frame, id, x, y, w, h, confidence, class, -1, -1` with MOTChallenge's class id in the
    eighth column (1 = pedestrian for `person`, -1 = unknown), where TrackEval reads it."""
    return (
        f"{frame},{track_id},{box.x:.2f},{box.y:.2f},{box.width:.2f},{box.height:.2f},"
        f"{confidence:.3f},{mot_class_id(label)},-1,-1"
    )


def write_mot(rows: list[str], path: Path) -> int:
    """Write `mot_row` rows to `path`; how many."""
    path.write_text("".join(row + "\n" for row in rows))
    return len(rows)


def centre_distance(box: Rect, window: Rect) -> float:
    """px from a box's centre to the camera window's centre (the centring error)."""
    return float(np.hypot(box.center[0] - window.center[0], box.center[1] - window.center[1]))


def every_object(gt: Path) -> Boxes:
    """Every ground-truth box of a gt.txt, ignored ones included (they are still real objects)."""
    boxes = load_mot(gt, ignored=True)
    for frame, frame_boxes in load_mot(gt).items():
        boxes.setdefault(frame, {}).update(frame_boxes)
    return boxes


def in_view(boxes: Boxes, windows: dict[int, Rect]) -> Boxes:
    """What the camera could see: the boxes whose centre lies inside that frame's camera window,
    clipped to the window (the part of the object the camera image shows)."""
    return {
        frame: {
            i: clipped
            for i, b in frame_boxes.items()
            if windows[frame].contains(*b.center)
            and (clipped := b.intersection(windows[frame])) is not None
        }
        for frame, frame_boxes in boxes.items()
        if frame in windows
    }


MIN_VIEW_SHARE = 0.5  # an object counts in view when half of its visible pixels are in the image


def visible_in_view(
    label_of: Callable[[int], np.ndarray],
    objects: Boxes,
    windows: dict[int, Rect],
    min_share: float = MIN_VIEW_SHARE,
) -> tuple[Boxes, Boxes]:
    """What each frame's camera image shows of each object, from the scene's label images
    (`label_of(frame)`, pixel value = object id, 0 = background): the tight box of the
    object's pixels inside the window.

    Returns (counted, partial). An object of `objects` with at least `min_share` of its visible
    pixels in the image is counted. One with fewer, but some, is a partial view (a head above
    the image's bottom edge), to be ignored: neither missed nor a false positive.

    Clipping the whole-scene box to the window (`in_view`) would keep, for a person cut by the
    image edge, the width of their stride below it: a box the image does not show."""
    counted: Boxes = {}
    partial: Boxes = {}
    for frame, window in windows.items():
        ids = objects.get(frame)
        if not ids:
            continue
        label = label_of(frame)
        totals = np.bincount(label.ravel())
        x0, y0, x1, y1 = _pixel_span(window, label.shape)
        crop = label[y0:y1, x0:x1]
        for object_id in ids:
            if object_id >= len(totals) or totals[object_id] == 0:
                continue
            rows, cols = np.nonzero(crop == object_id)
            if rows.size == 0:
                continue
            box = Rect(
                float(x0 + cols.min()),
                float(y0 + rows.min()),
                float(cols.max() - cols.min() + 1),
                float(rows.max() - rows.min() + 1),
            )
            share = rows.size / totals[object_id]
            (counted if share >= min_share else partial).setdefault(frame, {})[object_id] = box
    return counted, partial


def _pixel_span(window: Rect, shape: tuple[int, ...]) -> tuple[int, int, int, int]:
    """The pixels whose centres lie inside `window`, as slice bounds x0, y0, x1, y1."""
    height, width = shape[:2]

    def span(start: float, size: float, limit: int) -> tuple[int, int]:
        first = int(np.ceil(start - 0.5))
        end = int(np.ceil(start + size - 0.5))
        return max(0, first), min(limit, max(0, end))

    x0, x1 = span(window.x, window.width, width)
    y0, y1 = span(window.y, window.height, height)
    return x0, y0, x1, y1


def without_ignored(hypotheses: Boxes, truth: Boxes, ignored: Boxes, min_iou: float = 0.5) -> Boxes:
    """The hypotheses minus those on an ignored ground-truth object (IoU >= `min_iou` with it and
    with no counted object), as MOTChallenge drops matches to its distractors before scoring."""
    kept: Boxes = {}
    for frame, frame_boxes in hypotheses.items():
        skip = ignored.get(frame, {})
        counted = truth.get(frame, {})
        kept[frame] = {
            i: b
            for i, b in frame_boxes.items()
            if not skip
            or max((b.iou(g) for g in skip.values()), default=0.0) < min_iou
            or max((b.iou(g) for g in counted.values()), default=0.0) >= min_iou
        }
    return kept


@dataclass(frozen=True)
class MotScores:
    mota: float
    motp: float  # mean IoU distance (1 - IoU) of matches, as motmetrics reports it
    idf1: float
    id_switches: int
    recall: float
    precision: float
    frames: int


def clear_mot(
    truth: Boxes, hypotheses: Boxes, frames: list[int], max_iou_distance: float = 0.5
) -> MotScores:
    """CLEAR MOT and IDF1 of `hypotheses` against `truth` over `frames`."""
    accumulator = motmetrics.MOTAccumulator(auto_id=False)
    for frame in frames:
        truth_ids, truth_boxes = _columns(truth.get(frame, {}))
        hyp_ids, hyp_boxes = _columns(hypotheses.get(frame, {}))
        distances = iou_distances(truth_boxes, hyp_boxes, max_iou_distance)
        accumulator.update(truth_ids, hyp_ids, distances, frameid=frame)
    names = ["mota", "motp", "idf1", "num_switches", "recall", "precision", "num_frames"]
    row = motmetrics.metrics.create().compute(accumulator, metrics=names).iloc[0]
    return MotScores(
        mota=float(row["mota"]),
        motp=float(row["motp"]) if np.isfinite(row["motp"]) else float("nan"),
        idf1=float(row["idf1"]),
        id_switches=int(row["num_switches"]),
        recall=float(row["recall"]),
        precision=float(row["precision"]),
        frames=int(row["num_frames"]),
    )


@dataclass(frozen=True)
class HotaScores:
    hota: float  # HOTA averaged over the IoU thresholds 0.05 ... 0.95 (its definition)
    deta: float  # detection accuracy, same average
    assa: float  # association accuracy, same average
    hota_50: float  # HOTA at IoU 0.5 alone


def hota(truth: Boxes, hypotheses: Boxes, frames: list[int]) -> HotaScores:
    """HOTA (Luiten et al. 2021) of `hypotheses` against `truth` over `frames`, by trackeval."""
    truth_ids = sorted({i for f in frames for i in truth.get(f, {})})
    hyp_ids = sorted({i for f in frames for i in hypotheses.get(f, {})})
    truth_index = {i: n for n, i in enumerate(truth_ids)}
    hyp_index = {i: n for n, i in enumerate(hyp_ids)}
    data: dict = {"gt_ids": [], "tracker_ids": [], "similarity_scores": []}
    for frame in frames:
        t_ids, t_boxes = _columns(truth.get(frame, {}))
        h_ids, h_boxes = _columns(hypotheses.get(frame, {}))
        data["gt_ids"].append(np.array([truth_index[i] for i in t_ids], dtype=int))
        data["tracker_ids"].append(np.array([hyp_index[i] for i in h_ids], dtype=int))
        data["similarity_scores"].append(1.0 - iou_distances(t_boxes, h_boxes, np.inf))
    data["num_gt_ids"], data["num_tracker_ids"] = len(truth_ids), len(hyp_ids)
    data["num_gt_dets"] = sum(len(ids) for ids in data["gt_ids"])
    data["num_tracker_dets"] = sum(len(ids) for ids in data["tracker_ids"])
    result = HOTA().eval_sequence(data)
    alpha_50 = int(np.argmin(np.abs(np.arange(0.05, 0.99, 0.05) - 0.5)))
    return HotaScores(
        hota=float(np.mean(result["HOTA"])),
        deta=float(np.mean(result["DetA"])),
        assa=float(np.mean(result["AssA"])),
        hota_50=float(result["HOTA"][alpha_50]),
    )


def iou_distances(truth: np.ndarray, hypotheses: np.ndarray, max_distance: float) -> np.ndarray:
    """1 - IoU between (N, 4) and (M, 4) x, y, w, h boxes; NaN (no match) beyond `max_distance`.

    motmetrics' own iou_matrix calls np.asfarray, which NumPy 2 removed.
    """
    distance = 1.0 - iou_matrix(truth, hypotheses)
    distance[distance > max_distance] = np.nan
    return distance


def box_array(boxes: Iterable[Rect]) -> np.ndarray:
    """(N, 4) x, y, width, height of the boxes, in their order."""
    return np.array([[b.x, b.y, b.width, b.height] for b in boxes], dtype=float).reshape(-1, 4)


def _columns(boxes: dict[int, Rect]) -> tuple[list[int], np.ndarray]:
    ids = sorted(boxes)
    return ids, box_array(boxes[i] for i in ids)


@dataclass(frozen=True)
class FollowScores:
    followed_id: int | None  # the ground-truth object the camera followed most
    frames_after_lock: int
    inside_share: float  # frames after first lock with that object's centre inside the view
    mean_center_error_px: float  # its distance from the view centre, frames inside the view
    mean_center_error_share: float  # the same, as a share of the view width
    first_lock_frame: int | None


def follow_scores(
    truth: Boxes, windows: dict[int, Rect], targets: dict[int, tuple[float, float]]
) -> FollowScores:
    """How well the camera kept the followed object in view.

    `targets` holds the locked target's position per frame. The followed object is the one whose
    box contains the target position most often; figures count every frame from the first lock on.
    """
    votes = Counter(
        object_id
        for frame, (x, y) in targets.items()
        for object_id, box in truth.get(frame, {}).items()
        if box.contains(x, y)
    )
    if not votes:
        return FollowScores(None, 0, 0.0, float("nan"), float("nan"), None)
    followed = votes.most_common(1)[0][0]
    first_lock = min(targets)
    frames = [f for f in sorted(windows) if f >= first_lock and followed in truth.get(f, {})]
    inside, errors, shares = 0, [], []
    for frame in frames:
        window = windows[frame]
        cx, cy = truth[frame][followed].center
        if window.contains(cx, cy):
            inside += 1
            wx, wy = window.center
            errors.append(float(np.hypot(cx - wx, cy - wy)))
            shares.append(errors[-1] / window.width)
    return FollowScores(
        followed_id=followed,
        frames_after_lock=len(frames),
        inside_share=inside / len(frames) if frames else 0.0,
        mean_center_error_px=float(np.mean(errors)) if errors else float("nan"),
        mean_center_error_share=float(np.mean(shares)) if shares else float("nan"),
        first_lock_frame=first_lock,
    )
