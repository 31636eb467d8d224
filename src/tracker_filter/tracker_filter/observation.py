"""One frame's input to a tracker (no rclpy).

`Observation` carries what the frame offers: its time, the detector's `Detections` and presence
flag, and, when the tracker declares it `needs` them, the colour image, the detector's motion mask
and the camera window. The tracker node subscribes to and pairs only what its tracker needs; a
part that was needed but lost in transport is None, and the tracker must then treat the frame as a
miss rather than fail.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from enum import Enum
from typing import Protocol

import numpy as np

from tracker_msgs_py.codec import MAX_MESSAGE_VALUE
from tracker_msgs_py.geometry import Rect
from tracker_msgs_py.labels import label_array

AXES = 2  # the scene is a plane: x and y


class Need(Enum):
    """Inputs a tracker can ask for besides the detections (which every frame has)."""

    IMAGE = "image"  # camera image, BGR uint8 (H, W, 3), camera pixels (camera/image_raw)
    MASK = "mask"  # detector's motion mask, uint8 (H, W), camera pixels (detector/motion_mask)
    WINDOW = "window"  # the camera window in scene pixels (ptz/state)


class _Box(Protocol):
    @property
    def x(self) -> float: ...
    @property
    def y(self) -> float: ...
    @property
    def width(self) -> float: ...
    @property
    def height(self) -> float: ...


class BlobLike(Protocol):
    """What a detector's blob offers, as tracker_msgs/Blob or tracker_detect's `Blob`."""

    @property
    def centroid_x(self) -> float: ...
    @property
    def centroid_y(self) -> float: ...
    @property
    def area(self) -> float: ...
    @property
    def bbox(self) -> _Box: ...
    @property
    def score(self) -> float: ...
    @property
    def label(self) -> str: ...


@dataclass(frozen=True, eq=False)
class Detections:
    """Measurements of one frame: centroids (M, 2) px, areas (M,) px^2, boxes (M, 4) as x, y,
    width, height px, detector scores (M,) and class labels (M,) (all `labels.MOTION` when none
    are given)."""

    positions: np.ndarray
    areas: np.ndarray
    bboxes: np.ndarray
    scores: np.ndarray
    labels: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=object))

    def __post_init__(self) -> None:
        positions = np.asarray(self.positions, dtype=float).reshape(-1, AXES)
        count = len(positions)
        fields = {
            "positions": positions,
            "areas": np.asarray(self.areas, dtype=float).reshape(-1),
            "bboxes": np.asarray(self.bboxes, dtype=float).reshape(-1, 4),
            "scores": np.asarray(self.scores, dtype=float).reshape(-1),
        }
        for name, values in fields.items():
            if len(values) != count:
                raise ValueError(f"detections: {len(values)} {name} for {count} positions")
            object.__setattr__(self, name, values)
        given = None if len(self.labels) == 0 and count else self.labels
        object.__setattr__(self, "labels", label_array(given, count))

    @classmethod
    def empty(cls) -> Detections:
        return cls(np.zeros((0, AXES)), np.zeros(0), np.zeros((0, 4)), np.zeros(0))

    @classmethod
    def from_blobs(cls, blobs: Sequence[BlobLike], present: bool = True) -> Detections:
        """A detector's blobs as the tracker measures them (areas in whole pixels, as
        tracker_msgs/Blob carries them); none when the detector's presence test failed."""
        if not present or not blobs:
            return cls.empty()
        return cls(
            positions=np.array([(b.centroid_x, b.centroid_y) for b in blobs], dtype=float),
            areas=np.array([round(b.area) for b in blobs], dtype=float),
            bboxes=np.array(
                [(b.bbox.x, b.bbox.y, b.bbox.width, b.bbox.height) for b in blobs], dtype=float
            ),
            scores=np.array([b.score for b in blobs], dtype=float),
            labels=label_array((b.label for b in blobs), len(blobs)),
        )

    @classmethod
    def from_positions(
        cls, positions: np.ndarray, areas: np.ndarray | None = None, size: float = 0.0
    ) -> Detections:
        """Detections at `positions` with square boxes of side `size` (areas default to size^2)."""
        positions = np.asarray(positions, dtype=float).reshape(-1, AXES)
        count = len(positions)
        bboxes = np.column_stack([positions - size / 2.0, np.full((count, 2), size)])
        areas = np.full(count, size * size) if areas is None else areas
        return cls(positions, areas, bboxes, np.zeros(count))

    def __len__(self) -> int:
        return len(self.positions)

    def subset(self, indices: np.ndarray) -> Detections:
        return Detections(
            self.positions[indices],
            self.areas[indices],
            self.bboxes[indices],
            self.scores[indices],
            self.labels[indices],
        )

    def invalid_by_cause(self) -> dict[str, np.ndarray]:
        """Masks (M,) of the detections that cannot be measurements, by cause, in the order they
        are checked: a centroid, box, area or score that is not a finite number, a centroid or
        box beyond MAX_MESSAGE_VALUE, a box of negative size. `_all_valid` is the same rule
        over the whole frame at once: a new cause goes into both."""
        positions, boxes = self.positions, self.bboxes
        with np.errstate(invalid="ignore"):
            return {
                "non-finite centroid": ~np.isfinite(positions).all(axis=1),
                f"centroid beyond {MAX_MESSAGE_VALUE:g} px": (
                    np.abs(positions) > MAX_MESSAGE_VALUE
                ).any(axis=1),
                "non-finite box": ~np.isfinite(boxes).all(axis=1),
                f"box beyond {MAX_MESSAGE_VALUE:g} px": (np.abs(boxes) > MAX_MESSAGE_VALUE).any(
                    axis=1
                ),
                "negative box size": (boxes[:, 2:] < 0).any(axis=1),
                "non-finite or negative area": ~(np.isfinite(self.areas) & (self.areas >= 0)),
                f"score not finite or beyond {MAX_MESSAGE_VALUE:g}": ~(
                    np.abs(self.scores) <= MAX_MESSAGE_VALUE
                ),
            }

    def _all_valid(self) -> bool:
        """Whether no detection has any of `invalid_by_cause`'s faults: five reductions instead
        of the per-row masks of seven causes, for the usual frame. NaN fails every comparison."""
        positions, boxes, areas = self.positions, self.bboxes, self.areas
        return bool(
            (np.abs(positions) <= MAX_MESSAGE_VALUE).all()
            and (np.abs(boxes) <= MAX_MESSAGE_VALUE).all()
            and (boxes[:, 2:] >= 0).all()
            and ((areas >= 0) & (areas < np.inf)).all()
            and (np.abs(self.scores) <= MAX_MESSAGE_VALUE).all()
        )

    def validated(self) -> tuple[Detections, dict[str, int]]:
        """The usable detections, and how many were rejected by cause (each under its first)."""
        if self._all_valid():
            return self, {}
        rejected: dict[str, int] = {}
        remaining = np.ones(len(self), dtype=bool)
        for cause, invalid in self.invalid_by_cause().items():
            hit = remaining & invalid
            if hit.any():
                rejected[cause] = int(np.count_nonzero(hit))
                remaining &= ~hit
        return (self if remaining.all() else self.subset(remaining)), rejected


@dataclass(frozen=True, eq=False)
class Observation:
    """Everything a tracker gets for one frame.

    time: seconds on the tracker's time base (from header stamps; must increase step to step);
    detections: the detector's measurements in scene pixels; present: the detector's presence
    test; image / mask / window: only when the tracker `needs` them (None otherwise, or when lost).
    """

    time: float
    detections: Detections = field(default_factory=Detections.empty)
    present: bool = True
    image: np.ndarray | None = None
    mask: np.ndarray | None = None
    window: Rect | None = None
