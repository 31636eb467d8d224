"""Why a run's boxes miss: each in-view miss and each false box put in one class.

MOTA counts misses and false positives; to know what to fix, each is traced to a stage. Frame by
frame, the reported boxes are matched to the people in view at IoU >= 0.5 (Hungarian, as CLEAR
MOT's matching, without its carrying over of last frame's pairs). A person left unmatched is a
miss of one of these kinds, the first that applies:

- `shared_box`: a reported box covers them at IoU >= 0.5 but was matched to another person (one
  box over two people who overlap);
- `tentative_track`: a detection covers them at IoU >= 0.5 and a tentative track was updated
  with such a box (the tracker had not confirmed it yet);
- `not_reported`: a detection covers them at IoU >= 0.5, but no track reports it;
- `detection_too_big` / `detection_too_small` / `detection_off`: the detection that overlaps them
  most does so at IoU 0.1-0.5 and is over 1.3x their area (a sign or tape joined, two people in
  one blob), under 0.7x (legs lost, a half), or neither (shifted);
- `no_detection`: nothing overlaps them by 0.1.

A reported box left unmatched is a false positive: `overlaps_person` when it overlaps a person
in view at IoU >= 0.1 (a part, or a merge), else `on_nothing` (clutter).
"""

from __future__ import annotations

from collections import Counter

import numpy as np
from scipy.optimize import linear_sum_assignment

from tracker_msgs_py.geometry import Rect, iou_matrix
from tracker_ptz_sim.evaluation.metrics import Boxes, box_array

MATCH_IOU = 0.5
TOUCH_IOU = 0.1
TOO_BIG, TOO_SMALL = 1.3, 0.7  # detection area / person area

MISSES = (
    "shared_box",
    "tentative_track",
    "not_reported",
    "detection_too_big",
    "detection_too_small",
    "detection_off",
    "no_detection",
)
FALSE_POSITIVES = ("overlaps_person", "on_nothing")


def _matched(overlap: np.ndarray) -> tuple[set[int], set[int]]:
    """Rows and columns paired at IoU >= MATCH_IOU, most overlap first (Hungarian)."""
    if overlap.size == 0:
        return set(), set()
    rows, cols = linear_sum_assignment(-overlap)
    kept = overlap[rows, cols] >= MATCH_IOU
    return set(rows[kept].tolist()), set(cols[kept].tolist())


def _miss_kind(person: np.ndarray, detections: np.ndarray, tentative: np.ndarray) -> str:
    by_detection = iou_matrix(person[None], detections)[0]
    if by_detection.size and by_detection.max() >= MATCH_IOU:
        if tentative.size and iou_matrix(person[None], tentative)[0].max() >= MATCH_IOU:
            return "tentative_track"
        return "not_reported"
    if by_detection.size == 0 or by_detection.max() < TOUCH_IOU:
        return "no_detection"
    nearest = detections[int(np.argmax(by_detection))]
    ratio = (nearest[2] * nearest[3]) / max(person[2] * person[3], 1e-9)
    if ratio > TOO_BIG:
        return "detection_too_big"
    if ratio < TOO_SMALL:
        return "detection_too_small"
    return "detection_off"


def frame_errors(
    people: list[Rect], reported: list[Rect], detections: list[Rect], tentative: list[Rect]
) -> Counter[str]:
    """The classes of one frame's misses and false positives (see the module doc)."""
    truth, boxes = box_array(people), box_array(reported)
    found, shown = box_array(detections), box_array(tentative)
    overlap = iou_matrix(truth, boxes)
    hit_people, hit_boxes = _matched(overlap)
    counts: Counter[str] = Counter()
    for i in range(len(truth)):
        if i in hit_people:
            continue
        if overlap.shape[1] and overlap[i].max() >= MATCH_IOU:
            counts["shared_box"] += 1
        else:
            counts[_miss_kind(truth[i], found, shown)] += 1
    for j in range(len(boxes)):
        if j not in hit_boxes:
            touches = overlap.shape[0] > 0 and overlap[:, j].max() >= TOUCH_IOU
            counts["overlaps_person" if touches else "on_nothing"] += 1
    return counts


def error_classes(
    truth: Boxes,
    reported: Boxes,
    detections: dict[int, list[Rect]],
    tentative: dict[int, list[Rect]],
    frames: list[int],
) -> dict[str, int]:
    """Every class's count over `frames` (each class present, 0 when none), with the people and
    reported boxes counted as "people" and "reported"."""
    totals: Counter[str] = Counter({name: 0 for name in (*MISSES, *FALSE_POSITIVES)})
    for frame in frames:
        people = list(truth.get(frame, {}).values())
        boxes = list(reported.get(frame, {}).values())
        totals["people"] += len(people)
        totals["reported"] += len(boxes)
        totals.update(
            frame_errors(people, boxes, detections.get(frame, []), tentative.get(frame, []))
        )
    return dict(totals)
