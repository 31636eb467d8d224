"""The gated-Hungarian multi-target tracker, from small swappable components (no rclpy).

Stone Soup style: a `TrackManager` wires a filter factory (its bank steps every track), a
measurement selector, an associator (Mahalanobis gating + Hungarian assignment), an initiator, a
confirmation rule (M hits in the first N frames) and a deleter (consecutive misses); the shared
bookkeeping (ids, hits, misses, boxes, statuses) is a `tracking.TrackBook`. Seed 000's
single-target tracker is the configuration "largest detection only, at most one track, no gate,
confirmed on its first hit, deleted after 4 misses" (see `config.PRESETS["seed000"]`).

It is the registry's ``gated_hungarian`` tracker (`trackers.TRACKERS`); it needs only the
detections. Times are seconds from header stamps and must increase from step to step.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from scipy.optimize import linear_sum_assignment

from tracker_filter.filters import FilterFactory
from tracker_filter.gated_hungarian.association import Association, Associator
from tracker_filter.layout import StateLayout
from tracker_filter.object_scale import HeightByRow
from tracker_filter.observation import Detections, Need, Observation
from tracker_filter.tracking import TrackBook, TrackSet
from tracker_msgs_py.geometry import intersection_areas, iou_matrix

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


class Splitter(Protocol):
    def split(
        self, detections: Detections, boxes: np.ndarray, positions: np.ndarray, live: np.ndarray
    ) -> Detections: ...


class NoSplit:
    """Detections are measurements as they come."""

    def split(
        self, detections: Detections, boxes: np.ndarray, positions: np.ndarray, live: np.ndarray
    ) -> Detections:
        return detections


class MergedSplitter:
    """Split a detection that holds several tracked objects into one measurement per object.

    People walking together or crossing make one blob. When the predicted box centres of two or
    more `live` tracks (confirmed ones) lie inside a detection's box and that box is at least
    `min_growth` x the largest of their boxes in area, their boxes fill at least `MIN_FILL` of it,
    and no box lies half inside another (a head and a torso track on one person are parts of one
    object, not two objects), the detection is replaced by one piece per
    track: the track's box (its size, at most the detection's) at its predicted place, pushed
    inside the detection's box; the piece's centroid is the predicted position moved as far as
    its box was pushed, its area the detection's shared in proportion to the boxes' areas. So
    each track keeps its own box and identity while the group is one blob, and is still pulled
    by the blob's outline.
    """

    def __init__(self, min_growth: float = 1.25) -> None:
        if not min_growth >= 1.0:
            raise ValueError(f"min_growth must be >= 1, got {min_growth}")
        self.min_growth = min_growth

    def split(
        self, detections: Detections, boxes: np.ndarray, positions: np.ndarray, live: np.ndarray
    ) -> Detections:
        """`boxes` (N, 4) and `positions` (N, 2): the tracks' predicted boxes and centroids."""
        if len(detections) == 0 or np.count_nonzero(live) < 2:
            return detections
        centres = boxes[:, :2] + boxes[:, 2:] / 2.0
        kept, pieces = [], []
        for j, (x, y, w, h) in enumerate(detections.bboxes):
            inside = live & (
                (centres[:, 0] >= x)
                & (centres[:, 0] <= x + w)
                & (centres[:, 1] >= y)
                & (centres[:, 1] <= y + h)
            )
            members = np.flatnonzero(inside)
            if not self._holds_several(w * h, boxes[members]):
                kept.append(j)
                continue
            pieces.append(self._pieces(detections, j, boxes[members], positions[members]))
        if not pieces:
            return detections
        rest = detections.subset(np.array(kept, dtype=np.int64))
        return Detections(
            np.concatenate([rest.positions, *(p.positions for p in pieces)]),
            np.concatenate([rest.areas, *(p.areas for p in pieces)]),
            np.concatenate([rest.bboxes, *(p.bboxes for p in pieces)]),
            np.concatenate([rest.scores, *(p.scores for p in pieces)]),
            np.concatenate([rest.labels, *(p.labels for p in pieces)]),
        )

    def _holds_several(self, area: float, boxes: np.ndarray) -> bool:
        """Whether a detection box of `area` holds the objects of these predicted boxes."""
        areas = boxes[:, 2] * boxes[:, 3]
        return (
            len(boxes) >= 2
            and area >= self.min_growth * float(np.max(areas))
            and float(np.sum(areas)) >= MIN_FILL * area
            and not _nested(boxes)
        )

    @staticmethod
    def _pieces(
        detections: Detections, j: int, boxes: np.ndarray, positions: np.ndarray
    ) -> Detections:
        x, y, w, h = detections.bboxes[j]
        sizes = np.minimum(boxes[:, 2:], [w, h])
        corners = np.clip(boxes[:, :2], [x, y], [x + w, y + h] - sizes)
        shares = np.prod(sizes, axis=1) / max(float(np.sum(np.prod(sizes, axis=1))), 1e-12)
        return Detections(
            positions + (corners - boxes[:, :2]),
            detections.areas[j] * shares,
            np.column_stack([corners, sizes]),
            np.full(len(boxes), detections.scores[j]),
            np.full(len(boxes), detections.labels[j], dtype=object),
        )


MIN_FILL = 0.6  # share of a merged detection's box that its members' boxes cover


def _nested(boxes: np.ndarray) -> bool:
    """Whether any of the boxes (N, 4) has half its area or more inside another."""
    inter = intersection_areas(boxes, boxes)
    areas = boxes[:, 2] * boxes[:, 3]
    smaller = np.minimum.outer(areas, areas)
    inside = np.divide(inter, smaller, out=np.ones_like(inter), where=smaller > 0)
    np.fill_diagonal(inside, 0.0)
    return bool((inside >= 0.5).any())


class OverlapRecovery:
    """A second association by box overlap: a confirmed track and a detection that the centroid
    gate kept apart are paired when the track's predicted box and the detection's box overlap by
    at least `min_iou` (the most overlapping pairs first, Hungarian). A person's centroid jumps
    when the detector finds or loses their legs; their box still covers them. Tentative tracks
    are left to the gate: a blob of clutter that changes shape from frame to frame would
    otherwise collect the hits that confirm it."""

    def __init__(self, min_iou: float = 0.3) -> None:
        if not 0.0 < min_iou <= 1.0:
            raise ValueError(f"min_iou must be in (0, 1], got {min_iou}")
        self.min_iou = min_iou

    def recover(
        self,
        association: Association,
        boxes: np.ndarray,
        detection_boxes: np.ndarray,
        eligible: np.ndarray,
    ) -> Association:
        """`association` plus the pairs of `eligible` tracks (N,) -- their predicted `boxes`
        (N, 4) -- and free detections whose boxes overlap by `min_iou`."""
        free_tracks = eligible.copy()
        free_tracks[association.tracks] = False
        tracks = np.flatnonzero(free_tracks)
        measurements = association.unassigned_measurements(len(detection_boxes))
        if len(tracks) == 0 or len(measurements) == 0:
            return association
        iou = iou_matrix(boxes[tracks], detection_boxes[measurements])
        chosen_rows, chosen_cols = linear_sum_assignment(-iou)
        kept = iou[chosen_rows, chosen_cols] >= self.min_iou
        if not kept.any():
            return association
        all_tracks = np.concatenate([association.tracks, tracks[chosen_rows[kept]]])
        all_measurements = np.concatenate(
            [association.measurements, measurements[chosen_cols[kept]]]
        )
        order = np.argsort(all_tracks, kind="stable")
        return Association(all_tracks[order], all_measurements[order])


class BoxGate:
    """Per box edge, keep a track's edge where the detection's jumps away from it.

    A person's blob loses its legs for a few frames, or gains a strip of tape or a flickering
    sign joined above; its box then jumps by a third of the person's height or more, while a
    real change of size (walking towards the camera) is a few per cent a frame. Each edge (left,
    top, right, bottom) of an associated detection's box is compared with the track's predicted
    box: one that moved more than `tolerance` x the predicted height is replaced by the predicted
    edge, unless it has disagreed `patience` frames in a row (then the detection is believed: the
    object has changed). The detection's centroid moves with its box's centre, so the filter is
    corrected by the same cleaned measurement.

    With `scale` (the height rule's `HeightByRow`) the gate asks which box looks more like a
    person where it stands: the detection is believed at once when its height is at least as
    close to the learned height at its bottom row as the gated box's (ratio on a log scale). A
    track that was started on a merged or partial blob then takes the person's box when the
    detector finds it, instead of holding the wrong edges for `patience` frames. Until `scale`
    has learned its line nothing is held: a box that grows as its object comes into view cannot
    be told from one that joined a sign. The manager gates confirmed tracks only: a tentative
    track's box is still being found."""

    def __init__(
        self, tolerance: float = 0.2, patience: int = 5, scale: HeightByRow | None = None
    ) -> None:
        if not tolerance > 0 or patience < 1:
            raise ValueError(f"need tolerance > 0 and patience >= 1, got {tolerance}, {patience}")
        self.tolerance, self.patience = tolerance, patience
        self.scale = scale

    def gate(
        self,
        detections: Detections,
        rows: np.ndarray,
        cols: np.ndarray,
        predicted: np.ndarray,
        strikes: np.ndarray,
    ) -> Detections:
        """`detections` with the boxes and centroids of the associated ones (`cols`, paired with
        track rows `rows` whose predicted boxes are `predicted` (N, 4)) gated; `strikes` (N, 4),
        the consecutive disagreements per edge, is updated in place."""
        if len(rows) == 0 or (self.scale is not None and self.scale.line is None):
            return detections
        found = _edges(detections.bboxes[cols])
        expected = _edges(predicted[rows])
        height = np.maximum(predicted[rows, 3], 1.0)[:, None]
        off = np.abs(found - expected) > self.tolerance * height
        counted = np.where(off, strikes[rows] + 1, 0)
        keep = off & (counted < self.patience)
        held = _boxes(np.where(keep, expected, found))
        keep &= ~self._detection_fits(detections.bboxes[cols], held)[:, None]
        strikes[rows] = np.where(keep, counted, 0)
        edges = np.where(keep, expected, found)
        edges[:, 2] = np.maximum(edges[:, 2], edges[:, 0] + 1.0)
        edges[:, 3] = np.maximum(edges[:, 3], edges[:, 1] + 1.0)
        boxes = detections.bboxes.copy()
        positions = detections.positions.copy()
        gated = _boxes(edges)
        shift = (gated[:, :2] + gated[:, 2:] / 2) - (boxes[cols, :2] + boxes[cols, 2:] / 2)
        boxes[cols] = gated
        positions[cols] += shift
        return Detections(positions, detections.areas, boxes, detections.scores, detections.labels)

    def _detection_fits(self, detected: np.ndarray, held: np.ndarray) -> np.ndarray:
        """Per pair of boxes (N, 4), whether the detection's is at least as close to the learned
        height where it stands as the held one (all False without `scale`)."""
        if self.scale is None:
            return np.zeros(len(detected), dtype=bool)
        return _height_error(detected, self.scale) <= _height_error(held, self.scale)


def _height_error(boxes: np.ndarray, scale: HeightByRow) -> np.ndarray:
    """|log(height / learned height at the bottom row)| per box (N, 4)."""
    learned = np.maximum(scale.expected_heights(boxes), 1.0)
    result: np.ndarray = np.abs(np.log(np.maximum(boxes[:, 3], 1.0) / learned))
    return result


def _edges(boxes: np.ndarray) -> np.ndarray:
    """x, y, width, height (N, 4) -> left, top, right, bottom."""
    return np.column_stack([boxes[:, :2], boxes[:, :2] + boxes[:, 2:]])


def _boxes(edges: np.ndarray) -> np.ndarray:
    """left, top, right, bottom (N, 4) -> x, y, width, height."""
    return np.column_stack([edges[:, :2], edges[:, 2:] - edges[:, :2]])


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
    """A tentative track is confirmed once it has M hits within its first N frames and, when
    `min_travel` > 0, has moved at least that far (px) from where it was initiated, at least
    `min_straightness` of the way its detections went directly (net distance / path): a thing that
    flutters, sways or flickers in place is not a mover. It fails (is deleted) as soon as it can no
    longer get there: too few hits for M of N, or not travelled within `travel_window` frames.
    When `min_height` > 0 a track is confirmed only while its last box is at least that tall (px),
    and when `height_ratio` > 0 only while it is at least that share of the height the confirmed
    tracks have had where it stands (`object_scale.HeightByRow`, learned as they are observed:
    `learn`): most clutter that drifts (a healing ghost, a leaf, a flickering patch) is far
    smaller than a person at its place."""

    def __init__(
        self,
        hits: int = 3,
        window: int = 4,
        min_travel: float = 0.0,
        travel_window: int = 30,
        min_straightness: float = 0.0,
        path_step: float = 0.0,
        min_height: float = 0.0,
        height_ratio: float = 0.0,
    ) -> None:
        if not 1 <= hits <= window:
            raise ValueError(f"confirmation needs 1 <= M <= N, got M = {hits}, N = {window}")
        if not min_travel >= 0 or travel_window < 1:
            raise ValueError("min_travel must be >= 0 px and travel_window >= 1 frame")
        if not 0.0 <= min_straightness <= 1.0:
            raise ValueError(f"min_straightness must be in [0, 1], got {min_straightness}")
        self.hits, self.window = hits, window
        self.min_travel, self.travel_window = min_travel, travel_window
        self.min_straightness = min_straightness
        self.path_step = path_step  # px between the waypoints straightness is measured on
        if not min_height >= 0.0:
            raise ValueError(f"min_height must be >= 0 px, got {min_height}")
        self.min_height = min_height
        self.scale = HeightByRow(height_ratio) if height_ratio > 0 else None

    def confirmed(
        self,
        hits: np.ndarray,
        frames: np.ndarray,
        travel: np.ndarray,
        straightness: np.ndarray,
        boxes: np.ndarray,
    ) -> np.ndarray:
        """Which tracks pass now; `boxes` (N, 4) are their last measured boxes."""
        # A tentative track older than N frames has had its M hits (else it failed), so only
        # the travel (or the size) can still be missing.
        moved = (travel >= self.min_travel) & (straightness >= self.min_straightness)
        confirmed: np.ndarray = (hits >= self.hits) & moved & self._tall_enough(boxes)
        return confirmed

    def _tall_enough(self, boxes: np.ndarray) -> np.ndarray:
        least = self.min_height
        if self.scale is not None:
            least = np.maximum(least, self.scale.least_heights(boxes))
        return boxes[:, 3] >= least

    def learn(self, boxes: np.ndarray, observed: np.ndarray) -> None:
        """The height rule learns from the boxes (N, 4) of the tracks where `observed` (N,):
        the confirmed ones a detection updated this frame. Nothing is done without the rule."""
        if self.scale is not None:
            self.scale.observe(boxes[observed])

    def clear(self) -> None:
        """Forget what was learned."""
        if self.scale is not None:
            self.scale.clear()

    def failed(self, hits: np.ndarray, frames: np.ndarray, travel: np.ndarray) -> np.ndarray:
        stalled = (frames >= self.travel_window) & (travel < self.min_travel)
        failed: np.ndarray = (hits + (self.window - frames) < self.hits) | stalled
        return failed


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


# --- the manager -------------------------------------------------------------------------------


class TrackManager:
    """Predict, gate and assign, update, confirm, delete and initiate tracks, once per frame."""

    needs: frozenset[Need] = frozenset()

    def __init__(
        self,
        filter_factory: FilterFactory,
        associator: Associator,
        initiator: Initiator,
        confirmation: MofNConfirmation,
        deleter: Deleter,
        selector: MeasurementSelector | None = None,
        first_id: int = 1,
        splitter: Splitter | None = None,
        recovery: OverlapRecovery | None = None,
        box_gate: BoxGate | None = None,
    ) -> None:
        self.filter_factory = filter_factory
        self.associator = associator
        self.initiator = initiator
        self.confirmation = confirmation
        self.deleter = deleter
        self.selector = selector or AllDetections()
        self.splitter = splitter or NoSplit()
        self.recovery = recovery
        self.box_gate = box_gate
        self.bank = filter_factory.new_bank()
        self.layout = StateLayout.from_names(self.bank.state_layout)
        self.book = TrackBook(first_id, confirmation.path_step)
        self.rejected_measurements = 0

    @property
    def state_layout(self) -> tuple[str, ...]:
        return self.layout.names

    @property
    def time(self) -> float | None:
        return self.book.time

    @property
    def next_id(self) -> int:
        """The id the next initiated track gets."""
        return self.book.next_id

    def __len__(self) -> int:
        return len(self.book)

    def reset(self, reset_ids: bool = False) -> int:
        """Forget every track (and the last time, so any stamp is accepted next); returns how many."""
        self.bank.clear()
        self.confirmation.clear()
        return self.book.reset(reset_ids)

    def step(self, observation: Observation) -> TrackSet:
        """Process the detections of the frame at `observation.time` (s); every track after it.

        Raises OutOfOrderError (state unchanged) unless the time is after the previous step's.
        Invalid detections (`Detections.invalid_by_cause`) are dropped and counted
        (`TrackSet.rejections`, `rejected_measurements`).
        """
        t, book = observation.time, self.book
        book.check_time(t)
        detections, rejected = observation.detections.validated()
        self.rejected_measurements += sum(rejected.values())
        detections = self.selector.select(detections)

        self.bank.predict(t)
        predicted = self.layout.positions(self.bank.means)
        predicted_boxes = book.moved_boxes(predicted)
        detections = self.splitter.split(detections, predicted_boxes, predicted, book.confirmed)
        association = self.associator.associate(
            *self.bank.measurement_prediction(), detections.positions
        )
        if self.recovery is not None:
            association = self.recovery.recover(
                association, predicted_boxes, detections.bboxes, book.confirmed
            )
        rows, cols = association.tracks, association.measurements
        if self.box_gate is not None:
            held = book.confirmed[rows]  # a tentative track's box is still being found
            detections = self.box_gate.gate(
                detections, rows[held], cols[held], predicted_boxes, book.edge_strikes
            )
        self.bank.update(rows, detections.positions[cols])
        updated = book.record_frame(rows, cols, detections, self.layout.positions(self.bank.means))
        travel = book.measured_travel()
        book.confirm(
            self.confirmation.confirmed(
                book.hits, book.frames, travel, book.straightness(), book.bboxes
            )
        )
        self.confirmation.learn(book.bboxes, book.confirmed & updated)

        lost = self.deleter.lost(book.misses, book.confirmed) | (
            ~book.confirmed & self.confirmation.failed(book.hits, book.frames, travel)
        )
        new = self.initiator.initiate(
            detections,
            association.unassigned_measurements(len(detections)),
            len(book) - int(lost.sum()),
        )
        if len(new):
            self.bank.add(detections.positions[new])
            ones = np.ones(len(new), dtype=np.int64)
            confirmed = self.confirmation.confirmed(
                ones, ones, np.zeros(len(new)), np.ones(len(new)), detections.bboxes[new]
            )
            book.add(t, detections, new, confirmed)
        updated = np.concatenate([updated, np.ones(len(new), dtype=bool)])
        lost = np.concatenate([lost, np.zeros(len(new), dtype=bool)])

        tracks = book.snapshot(
            t,
            self.layout,
            self.bank.means.copy(),
            self.bank.covariances.copy(),
            updated,
            lost,
            rejected,
        )
        kept = ~lost
        if not kept.all():
            self.bank.keep(kept)
            book.keep(kept)
        book.finish(t)
        return tracks
