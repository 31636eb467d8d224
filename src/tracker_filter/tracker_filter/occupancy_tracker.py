"""Seed 002 on video: one particle filter per person on the detector's motion mask (no rclpy).

A `tracking.Tracker` (method `occupancy_particles`) that needs the motion mask and the camera
window. The mask (camera pixels) becomes a grid one cell deep whose cells are the camera pixels
placed in the scene through the window (`OccupancyGrid.from_mask`), and the seed's filters
(`occupancy_particles.OccupancyParticleFilters`) run on it in scene pixels: surface likelihood
over 7 x 7 camera pixels (the thesis's 3 x 3 voxels hold a 2 cm shell of a 40 cm person; 3 x 3
pixels of a 30 px one leave too few particles on its outline for a steady mean), blocking
ellipses sized by each other filter's box (`block_box_factor` x its width and height: the
thesis's 30 x 40 cm ellipsoid is about a person's size), jitter
D = `jitter_box_factor` x the filter's box (the thesis's D = room / N^(1/3) is about 1.5 people
wide; a D of the view's size / sqrt(N) leaves the cloud on one piece of a person's outline, one
as wide as the person lets it reach the next person),
the vertical opening of `opening` rows, initiation from connected components of at least
`min_area` px^2 and `min_height` px whose box holds no filter (an image has no floor to measure
the thesis's 60 cm on).

A filter is a hit in a frame when its surface mass is above `starve_weight` and its estimate
lies in a component; it reports that component's box (its part of it, when the component holds
several filters: two people in one blob) and the box's centre as its position (the cloud's mean
trails a walker: the filters have no motion model). Confirmed after `confirm_hits` hits that moved
`confirm_travel` px (a flutter in place never is); LOST when the core deletes it (starved or on
another's person). A frame without its mask or window is a miss for every filter, which do not
move. State layout "x y w h": the estimate and the box's size; no velocity (the filters have no
motion model).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from tracker_filter.layout import StateLayout
from tracker_filter.observation import Detections, Need, Observation
from tracker_filter.occupancy_grid import GridGeometry, OccupancyGrid
from tracker_filter.occupancy_particles import (
    BlockShape,
    FilterStep,
    Jitter,
    OccupancyFilterConfig,
    OccupancyParticleFilters,
    Propagation,
)
from tracker_filter.tracking import TrackBook, TrackSet
from tracker_msgs_py.params import ParamSpec
from tracker_msgs_py.registry import Method

LAYOUT = StateLayout.from_names("x y w h")
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
    """Seed 002's filters on motion masks, bookkept by a `TrackBook`."""

    needs = frozenset({Need.MASK, Need.WINDOW})
    layout = LAYOUT

    def __init__(
        self,
        config: OccupancyFilterConfig,
        min_area: float = 400.0,
        confirm_hits: int = 3,
        confirm_travel: float = 12.0,
        first_id: int = 1,
    ) -> None:
        self.config, self.min_area = config, min_area
        self.confirm_hits, self.confirm_travel = confirm_hits, confirm_travel
        self.book = TrackBook(first_id)
        self.filters = self._filters(first_id)
        self.geometry: GridGeometry | None = None

    def _filters(self, first_id: int) -> OccupancyParticleFilters:
        return OccupancyParticleFilters(self.config, first_id=first_id)

    @property
    def next_id(self) -> int:
        return self.book.next_id

    def reset(self, reset_ids: bool = False) -> int:
        count = self.book.reset(reset_ids)
        self.filters = self._filters(self.book.next_id)
        return count

    def step(self, observation: Observation) -> TrackSet:
        t, book = observation.time, self.book
        book.check_time(t)
        geometry = mask_geometry(observation)
        if geometry is None or observation.mask is None:
            return self._missed(t)
        if geometry.cell != getattr(self.geometry, "cell", None):
            # blobs are cells x cell edge: the area threshold in cells follows the zoom
            self.filters.config = replace(self.config, min_blob=self.min_area / geometry.cell[0])
        self.geometry = geometry
        result = self.filters.step(OccupancyGrid.from_mask(observation.mask, geometry))
        return self._record(t, result)

    def _missed(self, t: float) -> TrackSet:
        book = self.book
        rows = np.zeros(0, np.int64)
        updated = book.record_frame(rows, rows, Detections.empty(), self._positions())
        tracks = book.snapshot(
            t, LAYOUT, self._means(self._positions()), self._covariances(None), updated,
            np.zeros(len(book), bool), {},
        )  # fmt: skip
        book.finish(t)
        return tracks

    def _positions(self) -> np.ndarray:
        return self.filters.estimates[:, :2].copy()

    def _means(self, positions: np.ndarray) -> np.ndarray:
        return np.column_stack([positions, self.book.bboxes[:, 2:]])

    def _covariances(self, result: FilterStep | None) -> np.ndarray:
        out = np.tile(np.eye(LAYOUT.dim) * BOX_VARIANCE, (len(self.book), 1, 1))
        if result is not None:
            out[:, :2, :2] = result.covariances[:, :2, :2] + 1e-9 * np.eye(2)
        return out

    def _record(self, t: float, result: FilterStep) -> TrackSet:
        book, entering = self.book, ~result.started
        boxes = _boxes(result)
        # a hit is measured by its part of the blob: its centre, not the cloud's mean, which
        # trails a walker (no motion model)
        positions = np.where(
            result.measured[:, None], boxes[:, :2] + boxes[:, 2:] / 2, result.estimates[:, :2]
        )
        found = Detections(positions, boxes[:, 2] * boxes[:, 3], boxes, result.mass)
        rows = np.flatnonzero(result.measured & entering)
        updated = book.record_frame(rows, rows, found, positions[entering])
        book.confirm(
            (book.hits >= self.confirm_hits) & (book.measured_travel() >= self.confirm_travel)
        )
        new = np.flatnonzero(result.started)
        book.add(t, found, new, np.zeros(len(new), bool))
        updated = np.concatenate([updated, np.ones(len(new), bool)])
        tracks = book.snapshot(
            t, LAYOUT, self._means(positions), self._covariances(result), updated,
            result.deleted, {},
        )  # fmt: skip
        book.keep(~result.deleted)
        book.finish(t)
        return tracks


def _boxes(result: FilterStep) -> np.ndarray:
    """(R, 4) x, y, width, height px of every filter's box; a filter without one (it lies in no
    component) gets a 1 px box at its estimate, which no hit ever records."""
    lows, highs = result.lows[:, :2], result.highs[:, :2]
    missing = ~np.isfinite(lows).all(axis=1)
    lows = np.where(missing[:, None], result.estimates[:, :2] - 0.5, lows)
    highs = np.where(missing[:, None], result.estimates[:, :2] + 0.5, highs)
    return np.column_stack([lows, highs - lows])


PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("particles", 300, "particles per person (the thesis: 300 used, 50-1000)", 1, 100000),
    ParamSpec(
        "surface_radius",
        3,
        "likelihood neighbourhood half-size, camera px (1: the thesis's 3 x 3)",
        1,
        20,
    ),
    ParamSpec(
        "foreground_factor",
        False,
        "likelihood x the foreground share n1 / size of C (the thesis evaluated f = 1)",
    ),
    ParamSpec("blocking", True, "no particle inside another filter's ellipse"),
    ParamSpec(
        "block_box_factor", 0.75, "blocking ellipse semi-axes, x the other filter's box", 0.0, 10.0
    ),
    ParamSpec(
        "propagation",
        Propagation.NORMAL.value,
        "a taken pixel: nearest free one, or the nearest free foreground one",
        choices=tuple(p.value for p in Propagation),
    ),
    ParamSpec(
        "jitter",
        Jitter.NORMAL.value,
        "resampling jitter: view size / sqrt(N), or the thesis's expanded rule",
        choices=tuple(j.value for j in Jitter),
    ),
    ParamSpec(
        "jitter_box_factor",
        0.75,
        "resampling jitter, x the filter's box (0: the jitter rule alone; the thesis's room-wide "
        "jitter is about 1.5 people wide)",
        0.0,
        10.0,
    ),
    ParamSpec("opening", 5, "vertical opening of the mask, rows (1: off)", 1, 100),
    ParamSpec("min_area", 400.0, "px^2 a blob needs to start a filter", 0.0, 1e7),
    ParamSpec("min_height", 40.0, "px a blob needs to be tall to start a filter", 0.0, 1e5),
    ParamSpec("component_cell", 4.0, "px: blobs closer than this are one", 0.0, 1e3),
    ParamSpec("starve_weight", 0.01, "mean surface weight below which a frame starves", 0.0, 1.0),
    ParamSpec("starve_frames", 10, "starved frames after which a filter is deleted", 1, 10000),
    ParamSpec("confirm_hits", 3, "hits before a filter is a confirmed track", 1, 1000),
    ParamSpec("confirm_travel", 12.0, "px those hits must have moved", 0.0, 1e4),
    ParamSpec("seed", 0, "random seed (a replay gives the same tracks)", 0, 2**31 - 1),
)


def build(values: Mapping[str, Any], first_id: int = 1) -> OccupancyTracker:
    config = OccupancyFilterConfig(
        particles=values["particles"],
        radius=(values["surface_radius"], values["surface_radius"], 0),
        foreground_factor=values["foreground_factor"],
        blocking=values["blocking"],
        block_axes=(15.0, 40.0, 1.0),  # px, until a filter has a box
        block_shape=BlockShape.ELLIPSOID,  # an ellipse: in an image "up" is also "farther"
        block_box_factor=values["block_box_factor"],
        propagation=Propagation(values["propagation"]),
        jitter=Jitter(values["jitter"]),
        vertical_jitter_factor=1.0,
        jitter_box_factor=values["jitter_box_factor"],
        opening=values["opening"],
        component_cell=values["component_cell"],
        min_height=values["min_height"],
        exclusion_by_box=True,
        starve_weight=values["starve_weight"],
        starve_frames=values["starve_frames"],
        seed=values["seed"],
    )
    return OccupancyTracker(
        config,
        min_area=values["min_area"],
        confirm_hits=values["confirm_hits"],
        confirm_travel=values["confirm_travel"],
        first_id=first_id,
    )


METHOD: Method[Any] = Method(
    name="occupancy_particles",
    description="one particle filter per person on the motion mask, surface likelihood and "
    "blocking (seed 002)",
    build=build,
    parameters=PARAMETERS,
)
