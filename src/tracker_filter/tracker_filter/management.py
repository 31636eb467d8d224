"""Multi-target track management from small swappable components (no rclpy).

Stone Soup style: a `TrackManager` wires a filter factory (its bank steps every track), a
measurement selector, an associator (Mahalanobis gating + Hungarian assignment), an initiator, a
confirmation rule (M hits in the first N frames) and a deleter (consecutive misses). Seed 000's
single-target tracker is the configuration "largest detection only, at most one track, no gate,
confirmed on its first hit, deleted after 4 misses" (see `config.PRESETS["seed000"]`).

Times are seconds from header stamps and must increase from step to step; statuses match
tracker_msgs/Track: TENTATIVE, CONFIRMED (updated this cycle), COASTING (confirmed, missed this
cycle), LOST (reported once, in the cycle the track is deleted).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Protocol

import numpy as np

from tracker_filter.association import Associator
from tracker_filter.filters import FilterFactory
from tracker_filter.models import AXES, extrapolate_positions


class TrackStatus(IntEnum):
    TENTATIVE = 0
    CONFIRMED = 1
    COASTING = 2
    LOST = 3


MAX_COORDINATE_PX = 1e6  # farther from the scene origin is a corrupt message, not a detection


class OutOfOrderError(ValueError):
    """A step whose time is not after the previous step's; the tracker's state is unchanged."""


@dataclass(frozen=True, eq=False)
class Detections:
    """Measurements of one frame: centroids (M, 2) px, areas (M,) px^2, boxes (M, 4) as x, y,
    width, height px, and detector scores (M,)."""

    positions: np.ndarray
    areas: np.ndarray
    bboxes: np.ndarray
    scores: np.ndarray

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

    @classmethod
    def empty(cls) -> Detections:
        return cls(np.zeros((0, AXES)), np.zeros(0), np.zeros((0, 4)), np.zeros(0))

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
            self.positions[indices], self.areas[indices], self.bboxes[indices], self.scores[indices]
        )

    def invalid_by_cause(self) -> dict[str, np.ndarray]:
        """Masks (M,) of the detections that cannot be measurements, by cause, in the order they
        are checked: a centroid, box, area or score that is not a finite number, a centroid or
        box beyond MAX_COORDINATE_PX, a box of negative size."""
        positions, boxes = self.positions, self.bboxes
        with np.errstate(invalid="ignore"):
            return {
                "non-finite centroid": ~np.isfinite(positions).all(axis=1),
                f"centroid beyond {MAX_COORDINATE_PX:g} px": (
                    np.abs(positions) > MAX_COORDINATE_PX
                ).any(axis=1),
                "non-finite box": ~np.isfinite(boxes).all(axis=1),
                f"box beyond {MAX_COORDINATE_PX:g} px": (np.abs(boxes) > MAX_COORDINATE_PX).any(
                    axis=1
                ),
                "negative box size": (boxes[:, 2:] < 0).any(axis=1),
                "non-finite or negative area": ~(np.isfinite(self.areas) & (self.areas >= 0)),
                "non-finite score": ~np.isfinite(self.scores),
            }

    def validated(self) -> tuple[Detections, dict[str, int]]:
        """The usable detections, and how many were rejected by cause (each under its first)."""
        rejected: dict[str, int] = {}
        remaining = np.ones(len(self), dtype=bool)
        for cause, invalid in self.invalid_by_cause().items():
            hit = remaining & invalid
            if hit.any():
                rejected[cause] = int(np.count_nonzero(hit))
                remaining &= ~hit
        return (self if remaining.all() else self.subset(remaining)), rejected


# --- components --------------------------------------------------------------------------------


class MeasurementSelector(Protocol):
    def select(self, detections: Detections) -> Detections: ...


class AllDetections:
    """Every detection is a measurement (multi-target)."""

    def select(self, detections: Detections) -> Detections:
        return detections


class LargestDetection:
    """Only the largest detection is a measurement (seed 000 section 1, step 6)."""

    def select(self, detections: Detections) -> Detections:
        if len(detections) <= 1:
            return detections
        return detections.subset(np.array([int(np.argmax(detections.areas))]))


class Initiator(Protocol):
    def initiate(
        self, detections: Detections, free: np.ndarray, live_tracks: int
    ) -> np.ndarray: ...


class CappedInitiator:
    """Every unassociated detection starts a tentative track, largest first, up to max_tracks."""

    def __init__(self, max_tracks: int = 100) -> None:
        if max_tracks < 1:
            raise ValueError(f"max_tracks must be >= 1, got {max_tracks}")
        self.max_tracks = max_tracks

    def initiate(self, detections: Detections, free: np.ndarray, live_tracks: int) -> np.ndarray:
        room = max(self.max_tracks - live_tracks, 0)
        if room == 0 or len(free) == 0:
            return np.zeros(0, dtype=np.int64)
        by_size = free[np.argsort(-detections.areas[free], kind="stable")]
        return by_size[:room]


class MofNConfirmation:
    """A tentative track is confirmed once it has M hits within its first N frames, and fails
    (is deleted) as soon as it can no longer get there."""

    def __init__(self, hits: int = 3, window: int = 4) -> None:
        if not 1 <= hits <= window:
            raise ValueError(f"confirmation needs 1 <= M <= N, got M = {hits}, N = {window}")
        self.hits, self.window = hits, window

    def confirmed(self, hits: np.ndarray, frames: np.ndarray) -> np.ndarray:
        return (hits >= self.hits) & (frames <= self.window)

    def failed(self, hits: np.ndarray, frames: np.ndarray) -> np.ndarray:
        return hits + (self.window - frames) < self.hits


class Deleter(Protocol):
    def lost(self, misses: np.ndarray, confirmed: np.ndarray) -> np.ndarray: ...


class MissCountDeleter:
    """A track is lost after `max_misses` consecutive missed frames (seed 000: 4)."""

    def __init__(self, max_misses: int = 12) -> None:
        if max_misses < 1:
            raise ValueError(f"max_misses must be >= 1, got {max_misses}")
        self.max_misses = max_misses

    def lost(self, misses: np.ndarray, confirmed: np.ndarray) -> np.ndarray:
        return misses >= self.max_misses


# --- results -----------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class TrackReport:
    """One track of a `TrackSet`."""

    id: int
    status: TrackStatus
    mean: np.ndarray
    covariance: np.ndarray
    state_layout: tuple[str, ...]
    bbox: tuple[float, float, float, float]  # x, y, width, height px
    age: float  # s
    hits: int
    consecutive_misses: int
    existence: float
    area: float  # px^2 of the last associated detection
    detection: int  # index of the detection that updated it this frame, -1 if none

    @property
    def position(self) -> np.ndarray:
        return self.mean[:AXES]

    @property
    def velocity(self) -> np.ndarray:
        return self.mean[AXES : 2 * AXES]

    @property
    def position_covariance(self) -> np.ndarray:
        return self.covariance[:AXES, :AXES]


@dataclass(frozen=True, eq=False)
class TrackSet:
    """All tracks after one step (live ones and those LOST this step), as parallel arrays."""

    time: float
    state_layout: tuple[str, ...]
    ids: np.ndarray
    status: np.ndarray
    means: np.ndarray
    covariances: np.ndarray
    bboxes: np.ndarray
    ages: np.ndarray
    hits: np.ndarray
    misses: np.ndarray
    existence: np.ndarray
    areas: np.ndarray
    detections: np.ndarray
    rejections: dict[str, int] = field(default_factory=dict)  # invalid detections dropped, by cause

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def rejected_measurements(self) -> int:
        """Invalid detections dropped in this step."""
        return sum(self.rejections.values())

    def __iter__(self) -> Iterator[TrackReport]:
        return (self.report(i) for i in range(len(self)))

    @property
    def positions(self) -> np.ndarray:
        return self.means[:, :AXES]

    def index_of(self, track_id: int) -> int | None:
        found = np.flatnonzero(self.ids == track_id)
        return int(found[0]) if found.size else None

    def report(self, i: int) -> TrackReport:
        return TrackReport(
            id=int(self.ids[i]),
            status=TrackStatus(int(self.status[i])),
            mean=self.means[i],
            covariance=self.covariances[i],
            state_layout=self.state_layout,
            bbox=tuple(float(v) for v in self.bboxes[i]),
            age=float(self.ages[i]),
            hits=int(self.hits[i]),
            consecutive_misses=int(self.misses[i]),
            existence=float(self.existence[i]),
            area=float(self.areas[i]),
            detection=int(self.detections[i]),
        )

    def predicted_positions(self, lead: float) -> np.ndarray:
        """Positions (N, 2) the tracks reach `lead` seconds after `time`."""
        if len(self) == 0:
            return np.zeros((0, AXES))
        return extrapolate_positions(self.means, self.state_layout, lead)


class MultiTargetTracker(Protocol):
    """What the tracker node needs: `TrackManager` here, a GM-PHD tracker (seed 004) later."""

    @property
    def state_layout(self) -> tuple[str, ...]: ...

    @property
    def rejected_measurements(self) -> int: ...

    @property
    def next_id(self) -> int: ...

    def step(self, t: float, detections: Detections) -> TrackSet: ...

    def reset(self, reset_ids: bool = False) -> int: ...


# --- the manager -------------------------------------------------------------------------------


class TrackManager:
    """Predict, gate and assign, update, confirm, delete and initiate tracks, once per frame."""

    _INT_FIELDS = ("ids", "hits", "frames", "misses", "detections")

    def __init__(
        self,
        filter_factory: FilterFactory,
        associator: Associator,
        initiator: Initiator,
        confirmation: MofNConfirmation,
        deleter: Deleter,
        selector: MeasurementSelector | None = None,
        first_id: int = 1,
    ) -> None:
        self.filter_factory = filter_factory
        self.associator = associator
        self.initiator = initiator
        self.confirmation = confirmation
        self.deleter = deleter
        self.selector = selector or AllDetections()
        self.bank = filter_factory.new_bank()
        self.rejected_measurements = 0
        self._next_id = first_id
        self._clear()

    @property
    def state_layout(self) -> tuple[str, ...]:
        return self.bank.state_layout

    @property
    def time(self) -> float | None:
        return self._time

    @property
    def next_id(self) -> int:
        """The id the next initiated track gets."""
        return self._next_id

    def __len__(self) -> int:
        return len(self._ids)

    def _clear(self) -> None:
        self.bank.clear()
        self._time: float | None = None
        for name in self._INT_FIELDS:
            setattr(self, "_" + name, np.zeros(0, dtype=np.int64))
        self._born = np.zeros(0)
        self._confirmed = np.zeros(0, dtype=bool)
        self._bboxes = np.zeros((0, 4))
        self._anchors = np.zeros((0, AXES))  # estimated position when the box was measured
        self._areas = np.zeros(0)

    def reset(self, reset_ids: bool = False) -> int:
        """Forget every track (and the last time, so any stamp is accepted next); returns how many."""
        count = len(self)
        self._clear()
        if reset_ids:
            self._next_id = 1
        return count

    def step(self, t: float, detections: Detections) -> TrackSet:
        """Process the detections of the frame at time t (s); returns every track after it.

        Raises OutOfOrderError (state unchanged) unless t is after the previous step's time.
        Invalid detections (`Detections.invalid_by_cause`) are dropped and counted
        (`TrackSet.rejections`, `rejected_measurements`).
        """
        if not math.isfinite(t):
            raise OutOfOrderError(f"step time must be finite, got {t}")
        if self._time is not None and t <= self._time:
            raise OutOfOrderError(
                f"time {t:.6f} s is not after the previous frame's {self._time:.6f} s"
            )
        detections, rejected = detections.validated()
        self.rejected_measurements += sum(rejected.values())
        detections = self.selector.select(detections)

        self.bank.predict(t)
        association = self.associator.associate(
            *self.bank.measurement_prediction(), detections.positions
        )
        rows, cols = association.tracks, association.measurements
        self.bank.update(rows, detections.positions[cols])
        updated = self._record_frame(rows, cols, detections)

        lost = self.deleter.lost(self._misses, self._confirmed) | (
            ~self._confirmed & self.confirmation.failed(self._hits, self._frames)
        )
        new = self.initiator.initiate(
            detections,
            association.unassigned_measurements(len(detections)),
            len(self) - int(lost.sum()),
        )
        self._initiate(t, detections, new)
        updated = np.concatenate([updated, np.ones(len(new), dtype=bool)])
        lost = np.concatenate([lost, np.zeros(len(new), dtype=bool)])

        tracks = self._snapshot(t, updated, lost, rejected)
        self._keep(~lost)
        self._time = float(t)
        return tracks

    def _record_frame(
        self, rows: np.ndarray, cols: np.ndarray, detections: Detections
    ) -> np.ndarray:
        updated = np.zeros(len(self), dtype=bool)
        updated[rows] = True
        self._hits = self._hits + updated
        self._frames = self._frames + 1
        self._misses = np.where(updated, 0, self._misses + 1)
        self._detections = np.full(len(self), -1, dtype=np.int64)
        self._detections[rows] = cols
        self._bboxes[rows] = detections.bboxes[cols]
        self._areas[rows] = detections.areas[cols]
        self._anchors[rows] = self.bank.means[rows, :AXES]
        self._confirmed = self._confirmed | self.confirmation.confirmed(self._hits, self._frames)
        return updated

    def _initiate(self, t: float, detections: Detections, new: np.ndarray) -> None:
        count = len(new)
        if count == 0:
            return
        self.bank.add(detections.positions[new])
        ones = np.ones(count, dtype=np.int64)
        self._ids = np.concatenate([self._ids, np.arange(self._next_id, self._next_id + count)])
        self._next_id += count
        self._hits = np.concatenate([self._hits, ones])
        self._frames = np.concatenate([self._frames, ones])
        self._misses = np.concatenate([self._misses, 0 * ones])
        self._detections = np.concatenate([self._detections, new])
        self._born = np.concatenate([self._born, np.full(count, float(t))])
        self._confirmed = np.concatenate([self._confirmed, self.confirmation.confirmed(ones, ones)])
        self._bboxes = np.concatenate([self._bboxes, detections.bboxes[new]])
        self._anchors = np.concatenate([self._anchors, detections.positions[new]])
        self._areas = np.concatenate([self._areas, detections.areas[new]])

    def _snapshot(
        self, t: float, updated: np.ndarray, lost: np.ndarray, rejected: dict[str, int]
    ) -> TrackSet:
        status = np.where(
            self._confirmed,
            np.where(updated, TrackStatus.CONFIRMED, TrackStatus.COASTING),
            TrackStatus.TENTATIVE,
        )
        status = np.where(lost, TrackStatus.LOST, status).astype(np.uint8)
        means = self.bank.means.copy()
        bboxes = self._bboxes.copy()
        bboxes[:, :AXES] += means[:, :AXES] - self._anchors  # boxes move with coasting estimates
        return TrackSet(
            time=float(t),
            state_layout=self.state_layout,
            ids=self._ids.copy(),
            status=status,
            means=means,
            covariances=self.bank.covariances.copy(),
            bboxes=bboxes,
            ages=t - self._born,
            hits=self._hits.copy(),
            misses=self._misses.copy(),
            existence=np.ones(len(self)),
            areas=self._areas.copy(),
            detections=self._detections.copy(),
            rejections=rejected,
        )

    def _keep(self, mask: np.ndarray) -> None:
        if mask.all():
            return
        self.bank.keep(mask)
        for name in self._INT_FIELDS + ("born", "confirmed", "bboxes", "anchors", "areas"):
            setattr(self, "_" + name, getattr(self, "_" + name)[mask])
