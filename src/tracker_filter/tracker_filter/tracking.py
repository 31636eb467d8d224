"""The tracker plug-in shape: what every tracker is, returns and shares (no rclpy).

- `Tracker`: the protocol every multi-target tracker implements -- today's gated-Hungarian
  `management.TrackManager`, and the seed trackers (CamShift, particle filters, GM-PHD) as they
  come. It declares the inputs it `needs` (see `observation.Need`) and its state `layout`, and
  turns one `Observation` per frame into one `TrackSet`.
- `TrackSet` / `TrackReport`: all tracks after a step; statuses match tracker_msgs/Track.
- `TrackBook`: the bookkeeping every tracker shares -- ids and the next id, birth times, hits,
  misses, confirmation, boxes that move with coasting estimates, "LOST reported once", the step
  time check -- so a new tracker writes only its estimation.

Statuses: TENTATIVE, CONFIRMED (updated this cycle), COASTING (confirmed, missed this cycle),
LOST (reported once, in the cycle the track is deleted).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Protocol, runtime_checkable

import numpy as np

from tracker_filter.layout import StateLayout
from tracker_filter.models import extrapolate_positions
from tracker_filter.observation import AXES, Detections, Need, Observation
from tracker_msgs_py.geometry import Rect
from tracker_msgs_py.labels import MOTION, classified_over, label_array


class TrackStatus(IntEnum):
    TENTATIVE = 0
    CONFIRMED = 1
    COASTING = 2
    LOST = 3


class OutOfOrderError(ValueError):
    """A step whose time is not after the previous step's; the tracker's state is unchanged."""


@dataclass(frozen=True, eq=False)
class TrackReport:
    """One track of a `TrackSet`."""

    id: int
    status: TrackStatus
    mean: np.ndarray
    covariance: np.ndarray
    layout: StateLayout
    bbox: tuple[float, float, float, float]  # x, y, width, height px
    age: float  # s
    hits: int
    consecutive_misses: int
    existence: float
    area: float  # px^2 of the last associated detection
    detection: int  # index of the detection that updated it this frame, -1 if none
    label: str = MOTION  # class (labels.classified_over: a class once seen sticks)
    score: float = 0.0  # the last associated detection's score

    @property
    def state_layout(self) -> tuple[str, ...]:
        return self.layout.names

    @property
    def position(self) -> np.ndarray:
        return self.layout.positions(self.mean)

    @property
    def velocity(self) -> np.ndarray:
        return self.layout.velocities(self.mean)

    @property
    def position_covariance(self) -> np.ndarray:
        return self.layout.position_covariances(self.covariance)


def _no_labels() -> np.ndarray:
    return np.zeros(0, dtype=object)


def _no_scores() -> np.ndarray:
    return np.zeros(0)


@dataclass(frozen=True, eq=False)
class TrackSet:
    """All tracks after one step (live ones and those LOST this step), as parallel arrays.

    `state_layout` takes a `StateLayout` or the element names; `layout` is always the former.
    """

    time: float
    state_layout: tuple[str, ...] | StateLayout
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
    travel: np.ndarray | None = None  # px from where each track started (None: all 0)
    straightness: np.ndarray | None = None  # net distance / path of its detections (None: all 1)
    labels: np.ndarray = field(default_factory=_no_labels)  # class per track (none: all MOTION)
    scores: np.ndarray = field(default_factory=_no_scores)  # last detection's score (none: 0)
    layout: StateLayout = field(init=False)

    def __post_init__(self) -> None:
        given = self.state_layout
        layout = given if isinstance(given, StateLayout) else StateLayout.from_names(given)
        object.__setattr__(self, "layout", layout)
        object.__setattr__(self, "state_layout", layout.names)
        if self.travel is None:
            object.__setattr__(self, "travel", np.zeros(len(self.ids)))
        if self.straightness is None:
            object.__setattr__(self, "straightness", np.ones(len(self.ids)))
        if len(self.labels) != len(self.ids):
            object.__setattr__(self, "labels", label_array(None, len(self.ids)))
        if len(self.scores) != len(self.ids):
            object.__setattr__(self, "scores", np.zeros(len(self.ids)))

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
        return self.layout.positions(self.means)

    @property
    def velocities(self) -> np.ndarray:
        return self.layout.velocities(self.means)

    def index_of(self, track_id: int) -> int | None:
        found = np.flatnonzero(self.ids == track_id)
        return int(found[0]) if found.size else None

    def report(self, i: int) -> TrackReport:
        x, y, w, h = (float(v) for v in self.bboxes[i])
        return TrackReport(
            id=int(self.ids[i]),
            status=TrackStatus(int(self.status[i])),
            mean=self.means[i],
            covariance=self.covariances[i],
            layout=self.layout,
            bbox=(x, y, w, h),
            age=float(self.ages[i]),
            hits=int(self.hits[i]),
            consecutive_misses=int(self.misses[i]),
            existence=float(self.existence[i]),
            area=float(self.areas[i]),
            detection=int(self.detections[i]),
            label=str(self.labels[i]),
            score=float(self.scores[i]),
        )

    def predicted_positions(self, lead: float) -> np.ndarray:
        """Positions (N, 2) the tracks reach `lead` seconds after `time`."""
        if len(self) == 0:
            return np.zeros((0, AXES))
        return extrapolate_positions(self.means, self.layout, lead)


@runtime_checkable
class Tracker(Protocol):
    """A multi-target tracker: one `Observation` in, one `TrackSet` out, per frame.

    Contract (checked for every registered tracker by tests/filter/test_tracker_contract.py):
    - `step` returns every live track and, once, each track deleted in that step (LOST);
    - a step whose time is not after the previous one raises `OutOfOrderError` and changes nothing;
    - invalid detections are dropped and counted by cause in `TrackSet.rejections`;
    - ids are never reused, also after `reset()`, unless `reset(reset_ids=True)`;
    - every TrackSet's `layout` is the tracker's `layout`;
    - a needed input that is None (lost in transport) is a missed frame, not an error.
    """

    @property
    def needs(self) -> frozenset[Need]:
        """Inputs besides the detections that `step` reads from the Observation."""
        ...

    @property
    def layout(self) -> StateLayout:
        """The state layout of every track this tracker reports."""
        ...

    @property
    def next_id(self) -> int:
        """The id the next new track gets."""
        ...

    def step(self, observation: Observation) -> TrackSet:
        """Advance to `observation.time` and process the frame; returns every track after it."""
        ...

    def reset(self, reset_ids: bool = False) -> int:
        """Forget every track and the last time (any time is accepted next); how many there were."""
        ...


@runtime_checkable
class SeededTracker(Tracker, Protocol):
    """A tracker that can start a track from a rectangle the user draws (CamShift-style)."""

    def seed(self, rect: Rect, observation: Observation) -> int | None:
        """Start a track on `rect` (scene px) in the frame `observation`; its id, or None."""
        ...


class TrackBook:
    """Per-track bookkeeping shared by trackers: rows are tracks in the tracker's order.

    The tracker keeps its estimates (means, covariances) in the same row order, and per frame:
    `begin(t)` (time check), `record(rows, detections, cols, positions)` for the rows a detection
    updated, `mark_missed` / `confirm` rules via `record_frame`, `add(...)` for new tracks,
    `snapshot(...)` for the TrackSet, and `keep(mask)` to drop the rows LOST this frame.
    """

    _INT_FIELDS = ("ids", "hits", "frames", "misses", "detections")

    def __init__(self, first_id: int = 1, path_step: float = 0.0) -> None:
        self.next_id = first_id
        self.path_step = path_step  # px between the waypoints of `straightness`'s path
        self.clear()

    def __len__(self) -> int:
        return len(self.ids)

    def clear(self) -> None:
        """Forget every track and the time (the next id is kept)."""
        self.time: float | None = None
        self.ids = np.zeros(0, dtype=np.int64)
        self.hits = np.zeros(0, dtype=np.int64)
        self.frames = np.zeros(0, dtype=np.int64)
        self.misses = np.zeros(0, dtype=np.int64)
        self.detections = np.zeros(0, dtype=np.int64)
        self.born = np.zeros(0)
        self.confirmed = np.zeros(0, dtype=bool)
        self.bboxes = np.zeros((0, 4))
        self.edge_strikes = np.zeros((0, 4), dtype=np.int64)  # frames each box edge disagreed
        self.anchors = np.zeros((0, AXES))  # estimated position when the box was measured
        self.origins = np.zeros((0, AXES))  # the initiating detection's position
        self.measured = np.zeros((0, AXES))  # the last associated detection's position
        self.path = np.zeros(0)  # px walked from waypoint to waypoint (path_step apart)
        self.waypoints = np.zeros((0, AXES))  # the last detection counted in the path
        self.areas = np.zeros(0)
        self.labels = np.zeros(0, dtype=object)
        self.scores = np.zeros(0)

    def reset(self, reset_ids: bool = False) -> int:
        count = len(self)
        self.clear()
        if reset_ids:
            self.next_id = 1
        return count

    def check_time(self, t: float) -> None:
        """Raises OutOfOrderError unless t is finite and after the previous step's time."""
        if not math.isfinite(t):
            raise OutOfOrderError(f"step time must be finite, got {t}")
        if self.time is not None and t <= self.time:
            raise OutOfOrderError(
                f"time {t:.6f} s is not after the previous frame's {self.time:.6f} s"
            )

    def record_frame(
        self, rows: np.ndarray, cols: np.ndarray, detections: Detections, positions: np.ndarray
    ) -> np.ndarray:
        """Count a frame for every track: hits for `rows` (updated by detections `cols`, now at
        `positions` (N, 2) of all rows), misses for the others. Returns the updated mask."""
        updated = np.zeros(len(self), dtype=bool)
        updated[rows] = True
        self.hits = self.hits + updated
        self.frames = self.frames + 1
        self.misses = np.where(updated, 0, self.misses + 1)
        self.detections = np.full(len(self), -1, dtype=np.int64)
        self.detections[rows] = cols
        self.bboxes[rows] = detections.bboxes[cols]
        self.areas[rows] = detections.areas[cols]
        self.anchors[rows] = positions[rows]
        found = detections.positions[cols]
        hops = np.hypot(*(found - self.waypoints[rows]).T)
        counted = hops >= self.path_step
        self.path[rows[counted]] += hops[counted]
        self.waypoints[rows[counted]] = found[counted]
        self.measured[rows] = found
        self.labels[rows] = classified_over(self.labels[rows], detections.labels[cols])
        self.scores[rows] = detections.scores[cols]
        return updated

    def travel(self, positions: np.ndarray) -> np.ndarray:
        """Distance (px) of every track's `positions` (N, 2) from where it was initiated."""
        result: np.ndarray = np.hypot(*(positions - self.origins).T)
        return result

    def measured_travel(self) -> np.ndarray:
        """Distance (px) from each track's first detection to its last associated one (what the
        thing did, not what its filter predicts)."""
        result: np.ndarray = np.hypot(*(self.measured - self.origins).T)
        return result

    def straightness(self) -> np.ndarray:
        """Per track, how directly its detections moved: the distance from the first to the last
        divided by the path through them (1 for a walker, near 0 for a flutter in place; 1
        before a track has moved). The path goes from waypoint to waypoint, a detection being
        the next waypoint once it is `path_step` px from the last: a blob's centroid jitters by
        a few px from frame to frame as limbs come and go, which would make a slow walker's path
        many times their way."""
        net = self.measured_travel()
        path = self.path + np.hypot(*(self.measured - self.waypoints).T)
        straightness: np.ndarray = np.divide(net, path, out=np.ones(len(self)), where=path > 0)
        return straightness

    def moved_boxes(self, positions: np.ndarray) -> np.ndarray:
        """Every track's last measured box (N, 4), moved with its estimate to `positions` (N, 2)."""
        boxes = self.bboxes.copy()
        boxes[:, :AXES] += positions - self.anchors
        return boxes

    def confirm(self, confirmed: np.ndarray) -> None:
        """Tracks that pass the confirmation rule this frame stay confirmed."""
        self.confirmed = self.confirmed | confirmed

    def add(self, t: float, detections: Detections, new: np.ndarray, confirmed: np.ndarray) -> None:
        """New tracks, one per detection index in `new`, born at t with one hit."""
        count = len(new)
        if count == 0:
            return
        ones = np.ones(count, dtype=np.int64)
        self.ids = np.concatenate([self.ids, np.arange(self.next_id, self.next_id + count)])
        self.next_id += count
        self.hits = np.concatenate([self.hits, ones])
        self.frames = np.concatenate([self.frames, ones])
        self.misses = np.concatenate([self.misses, 0 * ones])
        self.detections = np.concatenate([self.detections, new])
        self.born = np.concatenate([self.born, np.full(count, float(t))])
        self.confirmed = np.concatenate([self.confirmed, confirmed])
        self.bboxes = np.concatenate([self.bboxes, detections.bboxes[new]])
        self.edge_strikes = np.concatenate([self.edge_strikes, np.zeros((count, 4), np.int64)])
        self.anchors = np.concatenate([self.anchors, detections.positions[new]])
        self.origins = np.concatenate([self.origins, detections.positions[new]])
        self.measured = np.concatenate([self.measured, detections.positions[new]])
        self.path = np.concatenate([self.path, np.zeros(count)])
        self.waypoints = np.concatenate([self.waypoints, detections.positions[new]])
        self.areas = np.concatenate([self.areas, detections.areas[new]])
        self.labels = np.concatenate([self.labels, detections.labels[new]])
        self.scores = np.concatenate([self.scores, detections.scores[new]])

    def snapshot(
        self,
        t: float,
        layout: StateLayout,
        means: np.ndarray,
        covariances: np.ndarray,
        updated: np.ndarray,
        lost: np.ndarray,
        rejections: dict[str, int],
        existence: np.ndarray | None = None,
    ) -> TrackSet:
        """The TrackSet of this frame; boxes move with the estimates since they were measured."""
        status = np.where(
            self.confirmed,
            np.where(updated, TrackStatus.CONFIRMED, TrackStatus.COASTING),
            TrackStatus.TENTATIVE,
        )
        status = np.where(lost, TrackStatus.LOST, status).astype(np.uint8)
        bboxes = self.moved_boxes(layout.positions(means))
        return TrackSet(
            time=float(t),
            state_layout=layout,
            ids=self.ids.copy(),
            status=status,
            means=means,
            covariances=covariances,
            bboxes=bboxes,
            ages=t - self.born,
            hits=self.hits.copy(),
            misses=self.misses.copy(),
            existence=np.ones(len(self)) if existence is None else existence,
            areas=self.areas.copy(),
            detections=self.detections.copy(),
            rejections=rejections,
            travel=self.travel(layout.positions(means)),
            straightness=self.straightness(),
            labels=self.labels.copy(),
            scores=self.scores.copy(),
        )

    def keep(self, mask: np.ndarray) -> None:
        """Drop the rows where `mask` is False (tracks reported LOST)."""
        if mask.all():
            return
        for name in self._INT_FIELDS + (
            "born",
            "confirmed",
            "bboxes",
            "edge_strikes",
            "anchors",
            "origins",
            "measured",
            "path",
            "waypoints",
            "areas",
            "labels",
            "scores",
        ):
            setattr(self, name, getattr(self, name)[mask])

    def finish(self, t: float) -> None:
        """The step at t is complete: later steps must come after it."""
        self.time = float(t)
