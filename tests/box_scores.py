"""Detector boxes against ground-truth boxes, one to one: the Hungarian assignment on IoU
(`Rect.iou`), a pair counting as a match at IoU >= `min_iou`, pooled over the frames added."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

from tracker_msgs_py.geometry import Rect


@dataclass
class BoxScore:
    min_iou: float = 0.5
    objects: int = 0
    blobs: int = 0
    matched: int = 0
    iou_sum: float = 0.0  # over the matches
    frames: int = 0
    count_close: int = 0  # frames with |blobs - objects| <= 1

    @property
    def recall(self) -> float:
        return self.matched / max(self.objects, 1)

    @property
    def precision(self) -> float:
        return self.matched / max(self.blobs, 1)

    @property
    def mean_iou(self) -> float:
        return self.iou_sum / max(self.matched, 1)

    def add(self, truth: list[Rect], found: list[Rect]) -> None:
        """One frame's ground-truth boxes and detected boxes."""
        self.frames += 1
        self.objects += len(truth)
        self.blobs += len(found)
        self.count_close += abs(len(found) - len(truth)) <= 1
        if not truth or not found:
            return
        ious = np.array([[t.iou(f) for f in found] for t in truth])
        rows, cols = linear_sum_assignment(-ious)
        good = ious[rows, cols] >= self.min_iou
        self.matched += int(good.sum())
        self.iou_sum += float(ious[rows, cols][good].sum())
