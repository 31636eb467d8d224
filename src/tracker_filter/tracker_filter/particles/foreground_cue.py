"""A foreground scale cue for particle filters: how well a box bounds the motion mask (no rclpy).

A colour histogram scores a box shrunk inside a person as well as the right one, and a box a
little too large nearly as well, so a colour filter's box keeps whatever size it starts with. A
motion detector's foreground mask (`detector/motion_mask`) says where the person's pixels are: the
right box holds all of them and as little else as it can. For a box B and its surroundings G (B
grown by `margin` x its size per side), with f the foreground pixels,

    precision  P = |f in B| / |B|                (the box's fill)
    recall     R = |f in B| / |f in G|           (the share of the nearby foreground it holds)
    F_beta     = (1 + beta^2) P R / (beta^2 P + R)

and a particle's weight is multiplied by max(F_beta, floor) ^ power. A person's silhouette fills
about 60 % of their box, and shrinking the box by a few rows mostly trades away thin limbs, so
recall has to count more than precision (beta 3) for the tight box to score highest; the power
makes the peak sharp enough for the cloud to follow a walker's stride.

A frame whose best box scores below `min_best` says nothing about this target (a person who
stopped and was learned into the background, a frame where the detector found nothing here): the
cue is then left out rather than pulling the cloud onto whatever moves nearby. Box sums come from
one integral image per frame (`ForegroundMask`, shared by every target's filter), four lookups
per box.

The fit (`fit` > 0): the weighted mean of a particle cloud is a blur of boxes, a few px off the
person on every side. The mask's blobs (8-connected) in the estimate's surroundings G that are
the estimate's (at least `FIT_MIN_INSIDE` of a blob's pixels inside it, or at least half of the
foreground inside it in the blob) bound the person more tightly: their box, clipped to G, is
blended into the reported box, `fit` of the way, when it overlaps the estimate by IoU >=
`fit_min_iou` (else it is someone else's blob, or legs the mask lost). Only the report moves:
pulling the cloud onto the blobs as well drew it onto people walking beside the target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from tracker_msgs_py.geometry import iou_matrix
from tracker_msgs_py.params import check_config

#: a blob is the estimate's when at least this share of its pixels lies inside it
FIT_MIN_INSIDE = 0.3


@dataclass(frozen=True, eq=False)
class ForegroundMask:
    """One frame's foreground mask, 0/1, and its (H + 1, W + 1) integral image: built once per
    frame, read by every filter that weighs boxes against it."""

    mask: np.ndarray
    integral: np.ndarray

    @classmethod
    def of(cls, mask: np.ndarray) -> ForegroundMask:
        """From a (H, W) mask, nonzero = foreground (0/1 or 0/255)."""
        binary = (np.asarray(mask) > 0).astype(np.uint8)
        return cls(binary, cv2.integral(binary))

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) of the mask."""
        return self.integral.shape[0] - 1, self.integral.shape[1] - 1


@dataclass(frozen=True)
class ForegroundCue:
    """Weights from a foreground mask (module doc); `power` 0 leaves the cue off."""

    power: float = 0.0
    beta: float = 3.0
    margin: float = 0.3
    floor: float = 0.05
    min_best: float = 0.2
    fit: float = 0.0  # the blobs' box's share in the reported box (0 = off)
    fit_min_iou: float = 0.4

    def problems(self) -> list[str]:
        """What is wrong with these values (empty when usable)."""
        checks = {
            "foreground power must be >= 0": math.isfinite(self.power) and self.power >= 0,
            "foreground beta must be > 0": math.isfinite(self.beta) and self.beta > 0,
            "foreground margin must be > 0": math.isfinite(self.margin) and self.margin > 0,
            "foreground floor must be in (0, 1]": 0.0 < self.floor <= 1.0,
            "foreground min_best must be in [0, 1]": 0.0 <= self.min_best <= 1.0,
            "foreground fit must be in [0, 1]": 0.0 <= self.fit <= 1.0,
            "foreground fit_min_iou must be in [0, 1]": 0.0 <= self.fit_min_iou <= 1.0,
        }
        return [message for message, ok in checks.items() if not ok]

    def __post_init__(self) -> None:
        check_config(self)

    @property
    def enabled(self) -> bool:
        return self.power > 0

    def scores(self, foreground: ForegroundMask, boxes: np.ndarray) -> np.ndarray:
        """F_beta of each box (N, 4: x, y, w, h in the mask's px) against the `foreground` mask;
        0 for a box with no foreground around it."""
        integral = foreground.integral
        boxes = np.asarray(boxes, dtype=float).reshape(-1, 4)
        inside, area = box_sums(integral, boxes)
        grown = boxes + np.column_stack(
            [-self.margin * boxes[:, 2:], 2 * self.margin * boxes[:, 2:]]
        )
        nearby, _ = box_sums(integral, grown)
        precision = inside / area
        recall = inside / np.maximum(nearby, 1)
        b2 = self.beta * self.beta
        f = (1 + b2) * precision * recall / np.maximum(b2 * precision + recall, 1e-12)
        return np.where(nearby > 0, f, 0.0)

    def weights(self, foreground: ForegroundMask, boxes: np.ndarray) -> np.ndarray | None:
        """Each box's weight factor, or None when the cue is off or the mask says nothing about
        these boxes (the best scores below `min_best`)."""
        if not self.enabled:
            return None
        f = self.scores(foreground, boxes)
        if not len(f) or float(f.max()) < self.min_best:
            return None
        factor: np.ndarray = np.maximum(f, self.floor) ** self.power
        return factor

    def fitted(self, foreground: ForegroundMask, box: np.ndarray) -> np.ndarray:
        """`box` (x, y, w, h in the mask's px) moved `fit` of the way to the box of its blobs
        (module doc); `box` itself when the fit is off or no blob of it overlaps it enough."""
        box = np.asarray(box, dtype=float)
        if self.fit <= 0:
            return box
        blobs = blob_box(foreground.mask, box, self.margin)
        if blobs is None or iou_matrix(box, blobs)[0, 0] < self.fit_min_iou:
            return box
        out: np.ndarray = box + self.fit * (blobs - box)
        return out


def blob_box(mask: np.ndarray, box: np.ndarray, margin: float) -> np.ndarray | None:
    """The box (x, y, w, h) of the blobs of the 0/1 `mask` that are `box`'s, within `box` grown
    by `margin` x its size per side and clipped to it (module doc); None when there are none."""
    height, width = mask.shape
    x, y, w, h = box
    gx0, gy0 = max(0, math.floor(x - margin * w)), max(0, math.floor(y - margin * h))
    gx1 = min(width, math.ceil(x + w + margin * w))
    gy1 = min(height, math.ceil(y + h + margin * h))
    if gx1 - gx0 < 2 or gy1 - gy0 < 2:
        return None
    count, labels, stats, _ = cv2.connectedComponentsWithStats(
        mask[gy0:gy1, gx0:gx1], connectivity=8
    )
    bx0, by0 = max(0, int(round(x)) - gx0), max(0, int(round(y)) - gy0)
    bx1, by1 = max(bx0, int(round(x + w)) - gx0), max(by0, int(round(y + h)) - gy0)
    inner = labels[by0:by1, bx0:bx1]
    inside = np.bincount(inner.ravel(), minlength=count)[1:]
    areas = stats[1:, cv2.CC_STAT_AREA]
    own = (inside >= FIT_MIN_INSIDE * areas) | (inside >= 0.5 * inside.sum())
    own &= inside > 0
    if not own.any():
        return None
    kept = stats[1:][own]
    x0, y0 = kept[:, cv2.CC_STAT_LEFT].min(), kept[:, cv2.CC_STAT_TOP].min()
    x1 = (kept[:, cv2.CC_STAT_LEFT] + kept[:, cv2.CC_STAT_WIDTH]).max()
    y1 = (kept[:, cv2.CC_STAT_TOP] + kept[:, cv2.CC_STAT_HEIGHT]).max()
    return np.array([gx0 + x0, gy0 + y0, x1 - x0, y1 - y0], dtype=float)


def box_sums(integral: np.ndarray, boxes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per box (x, y, w, h; outward-rounded and clipped to the image), the sum of the image whose
    (H + 1, W + 1) `integral` (cv2.integral) is given, and its pixel count (at least 1)."""
    height, width = integral.shape[0] - 1, integral.shape[1] - 1
    x0 = np.clip(np.floor(boxes[:, 0]), 0, width).astype(np.intp)
    y0 = np.clip(np.floor(boxes[:, 1]), 0, height).astype(np.intp)
    x1 = np.clip(np.ceil(boxes[:, 0] + boxes[:, 2]), 0, width).astype(np.intp)
    y1 = np.clip(np.ceil(boxes[:, 1] + boxes[:, 3]), 0, height).astype(np.intp)
    sums = integral[y1, x1] - integral[y0, x1] - integral[y1, x0] + integral[y0, x0]
    return sums.astype(float), np.maximum((x1 - x0) * (y1 - y0), 1).astype(float)
