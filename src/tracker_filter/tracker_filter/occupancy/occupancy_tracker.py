"""Seed 002 on video: one particle filter per person on the detector's motion mask (no rclpy).

A `tracking.Tracker` (method `occupancy_particles`) that needs the motion mask and the camera
window. The mask (camera pixels) becomes a grid one cell deep whose cells are the camera pixels
placed in the scene through the window (`OccupancyGrid.from_mask`), and the seed's filters
(`occupancy_particles.OccupancyParticleFilters`) run on it in scene pixels: surface likelihood
over 7 x 7 camera pixels (the thesis's 3 x 3 voxels hold a 2 cm shell of a 40 cm person; 3 x 3
pixels of a 30 px one leave too few particles on its outline for a steady mean), blocking
ellipses sized by each other filter's box (`block_box_factor` x its width and height: the
thesis's 30 x 40 cm ellipsoid is about a person's size), jitter D = `jitter_box_factor` x the
filter's box (the thesis's D = room / N^(1/3) is about 1.5 people wide; a D of the view's size /
sqrt(N) leaves the cloud on one piece of a person's outline, one as wide as the person lets it
reach the next person), the vertical opening of `opening` rows.

The detector's blobs do what the thesis's connected components do in 3-D, better on video (a
person's mask joins flicker and neighbours into blobs twice their size; the detector splits and
filters them): a filter owns the blob its estimate lies in (within `box_margin` x the blob's
size: the cloud trails a walker) if the blob is at least `size_gate` x the filter's last box (a
ghost or shadow speck left where a walker was measures nothing), and reports that blob's box and
its centre as its position; a blob several filters own (people walking together) is split
between them, each mask pixel going to the nearest estimate. A blob of at least `min_area` px^2
and `min_height` px that no filter owns starts one, its particles on the blob's mask pixels. A
filter that owns no blob takes its size from its part of the mask's connected blob around it.
Confirmed after `confirm_hits` hits that moved `confirm_travel` px with a straightness of at
least `confirm_straightness` (tape flutters in place); LOST after `max_misses` frames without a
blob, or when the core deletes it (starved, or on another filter's person). A frame without its
mask or window is a miss for every filter, which do not move. State layout "x y w h": the
position and the box's size; no velocity (the filters have no motion model).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from tracker_filter.layout import StateLayout
from tracker_filter.observation import Detections, Need, Observation
from tracker_filter.occupancy.occupancy_grid import GridGeometry, OccupancyGrid
from tracker_filter.occupancy.occupancy_particles import (
    BlockShape,
    Jitter,
    OccupancyFilterConfig,
    OccupancyParticleFilters,
    Propagation,
    split_cells,
)
from tracker_filter.tracking import TrackBook, TrackSet
from tracker_msgs_py.geometry import Rect
from tracker_msgs_py.params import check_config, param
from tracker_msgs_py.registry import Method

LAYOUT = StateLayout.from_names("x y w h")


@dataclass(frozen=True)
class BlobRules:
    """How the detector's blobs start, measure and confirm filters (px, scene)."""

    min_area: float = 400.0  # px^2 a blob needs to start a filter
    min_height: float = 40.0  # px
    box_margin: float = 0.25  # x its size: how far outside a blob's box a filter still owns it
    size_gate: float = 0.25  # a blob under this share of a filter's last box does not measure it
    max_misses: int = 10  # frames without a blob after which a filter is deleted
    confirm_hits: int = 3
    confirm_travel: float = 12.0  # px
    confirm_straightness: float = 0.7  # net distance / path: tape flutters in place
    straightness_step: float = 6.0  # px between the path's waypoints


_R = BlobRules()


@dataclass(frozen=True)
class OccupancyTrackerConfig:
    """Parameters of the `occupancy_particles` method: the filters' (`filter_config`) and the
    blob rules (`blob_rules`)."""

    particles: int = param(
        300, "particles per person (the thesis: 300 used, 50-1000)", min=1, max=100000
    )
    surface_radius: int = param(
        3,
        "likelihood neighbourhood half-size (1: the thesis's 3 x 3)",
        min=1,
        max=20,
        unit="camera px",
    )
    foreground_factor: bool = param(
        False, "likelihood x the foreground share n1 / size of C (the thesis evaluated f = 1)"
    )
    blocking: bool = param(True, "no particle inside another filter's ellipse")
    block_box_factor: float = param(
        0.75, "blocking ellipse semi-axes, x the other filter's box", min=0.0, max=10.0
    )
    propagation: str = param(
        Propagation.NORMAL.value,
        "a taken pixel: nearest free one, or the nearest free foreground one",
        choices=tuple(p.value for p in Propagation),
    )
    jitter: str = param(
        Jitter.NORMAL.value,
        "resampling jitter: view size / sqrt(N), or the thesis's expanded rule",
        choices=tuple(j.value for j in Jitter),
    )
    jitter_box_factor: float = param(
        0.75,
        "resampling jitter, x the filter's box (0: the jitter rule alone; the thesis's room-wide "
        "jitter is about 1.5 people wide)",
        min=0.0,
        max=10.0,
    )
    opening: int = param(5, "vertical opening of the mask, rows (1: off)", min=1, max=100)
    min_area: float = param(
        _R.min_area, "area a detector blob needs to start a filter", min=0.0, max=1e7, unit="px^2"
    )
    min_height: float = param(
        _R.min_height, "height a detector blob needs to start one", min=0.0, max=1e5, unit="px"
    )
    box_margin: float = param(
        _R.box_margin,
        "x a blob's size: how far outside its box a filter owns it",
        min=0.0,
        max=10.0,
    )
    size_gate: float = param(
        _R.size_gate,
        "a blob smaller than this share of a filter's last box does not measure it",
        min=0.0,
        max=1.0,
    )
    max_misses: int = param(
        _R.max_misses, "frames without a blob after which a filter is deleted", min=1, max=10000
    )
    starve_weight: float = param(
        0.01, "mean surface weight below which a frame starves", min=0.0, max=1.0
    )
    starve_frames: int = param(
        10, "starved frames after which a filter is deleted", min=1, max=10000
    )
    confirm_hits: int = param(
        _R.confirm_hits, "hits before a filter is a confirmed track", min=1, max=1000
    )
    confirm_travel: float = param(
        _R.confirm_travel, "distance those hits must have moved", min=0.0, max=1e4, unit="px"
    )
    confirm_straightness: float = param(
        _R.confirm_straightness,
        "... and that directly (net / path; tape flutters)",
        min=0.0,
        max=1.0,
    )
    straightness_step: float = param(
        _R.straightness_step,
        "distance between the waypoints of that path",
        min=0.0,
        max=1e3,
        unit="px",
    )
    seed: int = param(0, "random seed (a replay gives the same tracks)", min=0, max=2**31 - 1)

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        """Why this config is unusable beyond its fields' own ranges (empty when it is fine)."""
        return []

    def filter_config(self) -> OccupancyFilterConfig:
        radius = self.surface_radius
        return OccupancyFilterConfig(
            particles=self.particles,
            radius=(radius, radius, 0),
            foreground_factor=self.foreground_factor,
            blocking=self.blocking,
            block_shape=BlockShape.ELLIPSOID,  # an ellipse: in an image "up" is also "farther"
            block_axes=(15.0, 40.0, 1.0),  # px, until a filter has a box
            block_box_factor=self.block_box_factor,
            propagation=Propagation(self.propagation),
            jitter=Jitter(self.jitter),
            vertical_jitter_factor=1.0,
            jitter_box_factor=self.jitter_box_factor,
            opening=self.opening,
            starve_weight=self.starve_weight,
            starve_frames=self.starve_frames,
            seed=self.seed,
        )

    def blob_rules(self) -> BlobRules:
        return BlobRules(
            min_area=self.min_area,
            min_height=self.min_height,
            box_margin=self.box_margin,
            size_gate=self.size_gate,
            max_misses=self.max_misses,
            confirm_hits=self.confirm_hits,
            confirm_travel=self.confirm_travel,
            confirm_straightness=self.confirm_straightness,
            straightness_step=self.straightness_step,
        )


BOX_VARIANCE = 4.0  # px^2 reported for w and h (a component's box, not an estimate)


def mask_geometry(observation: Observation) -> GridGeometry | None:
    """The grid of the observation's mask in scene pixels, or None without mask or window."""
    mask, window = observation.mask, observation.window
    if mask is None or window is None or window.width <= 0 or mask.ndim != 2 or not mask.size:
        return None
    cell = window.width / mask.shape[1]
    return GridGeometry(
        (mask.shape[1], mask.shape[0], 1), (cell, cell, 1.0), (window.x, window.y, 0.0), 1
    )


class OccupancyTracker:
    """Seed 002's filters on motion masks, started on and boxed by the detector's blobs,
    bookkept by a `TrackBook`."""

    needs = frozenset({Need.MASK, Need.WINDOW})
    layout = LAYOUT

    def __init__(self, config: OccupancyTrackerConfig, first_id: int = 1) -> None:
        rules = config.blob_rules()
        self.config, self.rules = replace(config.filter_config(), initiation=False), rules
        self.book = TrackBook(first_id, path_step=rules.straightness_step)
        self.filters = OccupancyParticleFilters(self.config, first_id=first_id)

    @property
    def next_id(self) -> int:
        return self.book.next_id

    def reset(self, reset_ids: bool = False) -> int:
        count = self.book.reset(reset_ids)
        self.filters = OccupancyParticleFilters(self.config, first_id=self.book.next_id)
        return count

    def step(self, observation: Observation) -> TrackSet:
        t, book = observation.time, self.book
        book.check_time(t)
        geometry = mask_geometry(observation)
        detections, rejected = observation.detections.validated()
        if geometry is None or observation.mask is None:
            return self._missed(t, rejected)
        grid = OccupancyGrid.from_mask(observation.mask, geometry)
        result = self.filters.step(grid)
        owner = _owners(
            result.estimates,
            detections.bboxes,
            self.rules.box_margin,
            self.rules.size_gate * book.bboxes[:, 2] * book.bboxes[:, 3],
        )
        measured = (result.mass >= self.config.starve_weight) & (owner >= 0)
        boxes = self._boxes(grid, detections.bboxes, owner, measured, result.estimates)
        # a hit is measured by its blob: its centre, not the cloud's mean, which trails a
        # walker (no motion model)
        positions = np.where(
            measured[:, None], boxes[:, :2] + boxes[:, 2:] / 2, result.estimates[:, :2]
        )
        found = Detections(positions, boxes[:, 2] * boxes[:, 3], boxes, result.mass)
        rows = np.flatnonzero(measured)
        updated = book.record_frame(rows, rows, found, positions)
        # a filter without its person's blob for max_misses frames has lost them (it may live on
        # in the mask's leftovers: a ghost, a shadow)
        missing = (book.misses >= self.rules.max_misses) & ~result.deleted
        self.filters.remove(missing[~result.deleted])
        deleted = result.deleted | missing
        self._resize(grid, result.estimates[~deleted], boxes, measured, ~deleted)
        rules = self.rules
        book.confirm(
            (book.hits >= rules.confirm_hits)
            & (book.measured_travel() >= rules.confirm_travel)
            & (book.straightness() >= rules.confirm_straightness)
        )
        new = self._start(grid, detections, owner[~deleted])
        book.add(t, detections, new, np.zeros(len(new), bool))
        added = len(new)
        means = self._means(np.concatenate([positions, detections.positions[new]]))
        covariances = self._covariances(result.covariances, added)
        lost = np.concatenate([deleted, np.zeros(added, bool)])
        tracks = book.snapshot(
            t, LAYOUT, means, covariances, np.concatenate([updated, np.ones(added, bool)]),
            lost, rejected,
        )  # fmt: skip
        book.keep(~lost)
        book.finish(t)
        return tracks

    def _resize(
        self,
        grid: OccupancyGrid,
        estimates: np.ndarray,
        boxes: np.ndarray,
        measured: np.ndarray,
        alive: np.ndarray,
    ) -> None:
        """Each filter's size (its blocking ellipse and jitter follow it): its blob's box when
        it owns one, else its part of the mask's connected blob around its estimate (a person
        the detector missed or merged), else the size it had."""
        sizes = np.column_stack([boxes[alive, 2:], np.ones(alive.sum())])
        extents = np.where(measured[alive, None], sizes, self.filters.extents)
        loose = ~measured[alive]
        if loose.any():
            lows, highs = self.filters.blob_boxes(grid, estimates)
            blob = highs - lows
            use = loose & np.isfinite(blob[:, 0])
            extents[use] = blob[use]
        self.filters.extents = extents

    def _boxes(
        self,
        grid: OccupancyGrid,
        blobs: np.ndarray,
        owner: np.ndarray,
        measured: np.ndarray,
        estimates: np.ndarray,
    ) -> np.ndarray:
        """(M, 4) each measured filter's blob box; a blob several filters own (people walking
        together: one blob) is split among them, each mask pixel in it going to the nearest
        estimate (distances in units of each filter's box)."""
        boxes = np.zeros((len(owner), 4))
        boxes[measured] = blobs[owner[measured]]
        shared = np.bincount(owner[measured], minlength=len(blobs)) > 1
        extents = self.book.bboxes[:, 2:]  # each filter's last measured box
        for blob in np.flatnonzero(shared):
            rows = np.flatnonzero(measured & (owner == blob))
            inside = _in_box(grid.points, blobs[blob])
            if not inside.any():
                continue
            scale = np.ones((len(rows), 3))
            scale[:, :2] = np.maximum(extents[rows], 1.0)
            lows, highs = split_cells(grid.geometry, grid.cells[inside], estimates[rows], scale)
            got = np.isfinite(lows[:, 0])
            boxes[rows[got]] = np.column_stack([lows[got, :2], (highs - lows)[got, :2]])
        return boxes

    def _start(self, grid: OccupancyGrid, detections: Detections, owner: np.ndarray) -> np.ndarray:
        """Start a filter on every person-sized blob no filter holds; their detection indices."""
        boxes, rules = detections.bboxes, self.rules
        big = (boxes[:, 2] * boxes[:, 3] >= rules.min_area) & (boxes[:, 3] >= rules.min_height)
        free = big & ~np.isin(np.arange(len(detections)), owner)
        started = []
        for i in np.flatnonzero(free):
            x, y, w, h = boxes[i]
            inside = _in_box(grid.points, boxes[i])
            if not inside.any():
                continue
            cells = grid.points[inside]
            centre = np.array([x + w / 2, y + h / 2, cells[0, 2]])
            self.filters.start(cells, centre, np.array([w, h, 0.0]))
            started.append(i)
        return np.array(started, dtype=np.int64)

    def _missed(self, t: float, rejected: dict[str, int]) -> TrackSet:
        book = self.book
        rows = np.zeros(0, np.int64)
        positions = self.filters.estimates[:, :2].copy()
        updated = book.record_frame(rows, rows, Detections.empty(), positions)
        covariances = np.tile(np.eye(LAYOUT.dim) * BOX_VARIANCE, (len(book), 1, 1))
        tracks = book.snapshot(
            t, LAYOUT, self._means(positions), covariances, updated,
            np.zeros(len(book), bool), rejected,
        )  # fmt: skip
        book.finish(t)
        return tracks

    def _means(self, positions: np.ndarray) -> np.ndarray:
        return np.column_stack([positions, self.book.bboxes[:, 2:]])

    def _covariances(self, particles: np.ndarray, added: int) -> np.ndarray:
        out = np.tile(np.eye(LAYOUT.dim) * BOX_VARIANCE, (len(particles) + added, 1, 1))
        out[: len(particles), :2, :2] = particles[:, :2, :2] + 1e-9 * np.eye(2)
        return out


def _in_box(points: np.ndarray, box: np.ndarray) -> np.ndarray:
    """Which points (P, >= 2) lie in the box x, y, width, height."""
    x, y, w, h = box
    result: np.ndarray = (
        (points[:, 0] >= x) & (points[:, 0] <= x + w) & (points[:, 1] >= y)
        & (points[:, 1] <= y + h)
    )  # fmt: skip
    return result


def _owners(
    estimates: np.ndarray, boxes: np.ndarray, margin: float, min_areas: np.ndarray
) -> np.ndarray:
    """Per estimate (M, >=2), the detection box (N, 4) it lies in, widened by `margin` x its
    size (the cloud trails a walker), of at least the estimate's `min_areas` (M,) px^2, the
    nearest centre of several; -1 for none."""
    if not len(boxes) or not len(estimates):
        return np.full(len(estimates), -1, np.int64)
    low = boxes[:, :2] - margin * boxes[:, 2:]
    high = boxes[:, :2] + (1 + margin) * boxes[:, 2:]
    points = estimates[:, None, :2]
    inside = ((points >= low[None]) & (points <= high[None])).all(axis=-1)
    inside &= (boxes[:, 2] * boxes[:, 3])[None, :] >= min_areas[:, None]
    distance = np.linalg.norm(points - (boxes[None, :, :2] + boxes[None, :, 2:] / 2), axis=-1)
    nearest = np.argmin(np.where(inside, distance, np.inf), axis=1)
    result: np.ndarray = np.where(np.any(inside, axis=1), nearest, -1)
    return result


def warm_up() -> None:
    """Step a throwaway tracker through two blobs that cross (every kernel of the step runs:
    snapping, likelihood, blocking, resampling, the split of a shared blob), so numba compiles
    them, or loads them from its cache, now rather than on a replay's first frames."""
    tracker = OccupancyTracker(OccupancyTrackerConfig(particles=20, opening=3))
    window = Rect(0.0, 0.0, 120.0, 80.0)
    for k in range(10):
        mask = np.zeros((80, 120), np.uint8)
        boxes = np.array([[10.0 + 6 * k, 10.0, 12.0, 45.0], [98.0 - 6 * k, 20.0, 12.0, 45.0]])
        for x, y, w, h in boxes.astype(int):
            mask[y : y + h, x : x + w] = 1
        found = Detections(
            boxes[:, :2] + boxes[:, 2:] / 2, boxes[:, 2] * boxes[:, 3], boxes, np.ones(2)
        )
        tracker.step(Observation(0.1 * k, found, mask=mask, window=window))


METHOD: Method[Any] = Method.of(
    name="occupancy_particles",
    description="one particle filter per person on the motion mask, surface likelihood and "
    "blocking (seed 002)",
    config=OccupancyTrackerConfig,
    make=OccupancyTracker,
    warm_up=warm_up,
)
