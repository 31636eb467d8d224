"""Seed 002: one SIR particle filter per person on an occupancy grid, with blocking (no rclpy).

López Méndez 2007 (digest: ../shared/seeds/002-multi-person-pf-voxels.md). The same code runs on
3-D voxel volumes and on 2-D foreground masks (a grid one cell deep, `occupancy_grid`). Per
frame, for every filter j at once:

(a) propagation without a motion model: each particle is snapped to its cell, at most one
    particle per cell; a particle whose cell is taken moves to the nearest free cell (the
    "ranking" variant: the nearest free foreground cell, else the nearest free one);
(b) the surface-assimilation likelihood (eq. 3.8), over the neighbourhood C of the particle's cell
    (3 x 3 x 3, |C| = 27; 3 x 3 on a mask), n1 / n0 its foreground / background cells (a cell
    outside the grid counts as the nearest one inside: a person standing on the grid's floor has
    no surface there; the thesis does not say, and as background it draws every cloud to the
    feet):
        w = f(n1) * (1 - |n1 - n0| / |C|),   f = 1 (as evaluated) or f = n1 / |C|;
(c) blocking: w = 0 for a particle inside the ellipsoid around another filter's previous
    estimate, ((dx/a)^2 + (dy/b)^2 + (dz/c)^2 <= 1; the thesis's a = 30, b = 40 cm, c = that
    filter's centroid height), or (`block_shape` "cylinder", the default) inside the same
    ellipse at every height (two people never share a column of the room): the ellipsoid
    narrows towards the floor, so a filter next to another keeps its partner's legs, sinks
    towards them, its own ellipsoid flattens with its estimate, and the two swap;
(d) estimate: the weighted mean of the particles;
(e) systematic resampling, each particle then jittered by U[-D/2, D/2] per axis,
    D = extent / N^(1/d) (d the grid's dimensions; the vertical axis doubled: "normal"), or
    the "expanded" rule D = 3.9 sqrt(h) N^(1/3) exp(-N h / 20000) cm, h the voxel edge in cm.

Scene filtering before (a): the exclusion mask (doors) and the vertical opening. Initiation after
(e): a connected component is a person when cells x cell edge > `min_blob` (the thesis: 3000
voxel cm = 30 voxel m) and its vertical extent >= `min_height` (60 cm); a filter starts at its
centre of mass, its particles on the component's cells, unless a filter's estimate is within
`exclusion` (60 cm, measured on the floor: the axes other than the vertical).

Deletion (the thesis leaves it open; ours): a filter is deleted when its mean weight after
blocking stays below `starve_weight` for `starve_frames` frames (it lost its person, or another
filter's ellipsoid covers its whole cloud), or when its estimate stays inside another filter's
ellipsoid shrunk by `overlap_scale` (0.5) for `overlap_frames` frames (two filters on one person:
the younger goes; people in contact are closer than the whole ellipsoid). Without
blocking, the filters of two people in contact coalesce and one is deleted by the second rule.

Each filter also gets the box of the component its estimate lies in (within half the jitter
width: a cloud without a motion model trails its person); a component holding several
estimates is split among them, every cell going to the nearest estimate (scaled by the blocking
axes). One seeded generator drives the resampling and jitter: a replay gives the same tracks.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numba
import numpy as np

from tracker_filter.occupancy.occupancy_grid import (
    Components,
    GridGeometry,
    OccupancyGrid,
    components,
)

MAX_STAMP = 2**31 - 2


class Propagation(Enum):
    NORMAL = "normal"  # a taken cell: the nearest free one
    RANKING = "ranking"  # the nearest free foreground cell first (the thesis: worse)


class BlockShape(Enum):
    ELLIPSOID = "ellipsoid"  # the thesis's: (dx/a)^2 + (dy/b)^2 + (dz/c)^2 <= 1
    CYLINDER = "cylinder"  # the ellipse (dx/a)^2 + (dy/b)^2 <= 1 at every height


class Jitter(Enum):
    NORMAL = "normal"  # D = extent / N^(1/d), vertical doubled
    EXPANDED = "expanded"  # D = 3.9 sqrt(h) N^(1/3) exp(-N h / 20000) cm (the thesis: worse)


@dataclass(frozen=True)
class OccupancyFilterConfig:
    """Parameters of `OccupancyParticleFilters`; lengths in the grid's world units (metres for
    voxels: the defaults are the thesis's; scene pixels for masks)."""

    particles: int = 300
    radius: tuple[int, int, int] = (1, 1, 1)  # C's half-size per axis in cells: 3 x 3 x 3
    foreground_factor: bool = False  # f = n1 / |C| instead of 1
    blocking: bool = True
    block_axes: tuple[float, float, float] = (0.30, 0.40, 0.0)  # 0: the estimate's height
    block_shape: BlockShape = BlockShape.CYLINDER
    block_box_factor: float = 0.0  # > 0: semi-axes = this x the filter's box (once it has one)
    propagation: Propagation = Propagation.NORMAL
    jitter: Jitter = Jitter.NORMAL
    vertical_jitter_factor: float = 2.0
    jitter_box_factor: float = 0.0  # > 0: D = this x the filter's box, once it has one
    opening: int = 5  # vertical opening, cells (1: off)
    component_cell: float = 0.08  # components are labelled on cells about this large
    min_blob: float = 30.0  # cells x cell edge
    min_height: float = 0.60
    exclusion: float = 0.60
    initiation: bool = True  # start and box filters on blobs (off: the caller uses `start`)
    starve_weight: float = 0.01
    starve_frames: int = 10
    overlap_frames: int = 3
    overlap_scale: float = 0.5  # "on one person": inside this x the other's ellipsoid
    seed: int = 0

    def problems(self) -> list[str]:
        found = []
        if self.particles < 1:
            found.append(f"particles must be >= 1, got {self.particles}")
        if min(self.radius) < 0:
            found.append(f"radius must be >= 0 per axis, got {self.radius}")
        if min(self.block_axes) < 0:
            found.append(f"block_axes must be >= 0, got {self.block_axes}")
        if self.starve_frames < 1 or self.overlap_frames < 1:
            found.append("starve_frames and overlap_frames must be >= 1")
        return found


@dataclass(frozen=True)
class FilterStep:
    """What one step did, one row per filter: the filters that entered the step (those deleted
    in it included, `deleted` set) followed by those it started (`started` set).

    estimates (R, 3) and covariances (R, 3, 3) of the weighted particles; lows / highs (R, 3): the
    box of the filter's component part (NaN when its estimate is in no component); mass (R,): the
    mean weight after blocking; measured: mass >= starve_weight and a component found."""

    ids: np.ndarray
    estimates: np.ndarray
    covariances: np.ndarray
    lows: np.ndarray
    highs: np.ndarray
    mass: np.ndarray
    measured: np.ndarray
    deleted: np.ndarray
    started: np.ndarray
    frames: np.ndarray  # frames each filter has lived
    travel: np.ndarray  # farthest each estimate has been from where it started, on the floor
    components: Components
    grid: OccupancyGrid  # the filtered grid the filters saw

    def __len__(self) -> int:
        return len(self.ids)


def surface_weight(n1: np.ndarray, size: int, foreground_factor: bool = False) -> np.ndarray:
    """Eq. 3.8: w = f(n1) (1 - |n1 - n0| / |C|), n0 = |C| - n1, f = 1 or n1 / |C|."""
    n1 = np.asarray(n1, dtype=float)
    weight = 1.0 - np.abs(2.0 * n1 - size) / size
    return weight * n1 / size if foreground_factor else weight


def jitter_widths(
    config: OccupancyFilterConfig, geometry: GridGeometry
) -> np.ndarray:  # (3,) world units
    """D per axis of step (e)."""
    n = config.particles
    if config.jitter is Jitter.EXPANDED:
        h = geometry.cell[0] * 100.0  # the rule is in cm
        width = 3.9 * np.sqrt(h) * np.cbrt(n) * np.exp(-n * h / 20000.0) / 100.0
        return np.full(3, width)
    extent = np.asarray(geometry.size, dtype=float)
    dims = sum(1 for s in geometry.shape if s > 1)
    widths: np.ndarray = extent / n ** (1.0 / max(dims, 1))
    widths[geometry.vertical] *= config.vertical_jitter_factor
    widths[np.asarray(geometry.shape) == 1] = 0.0
    return widths


class OccupancyParticleFilters:
    """Seed 002's tracker core: M filters of N particles, stepped together on each grid."""

    def __init__(
        self,
        config: OccupancyFilterConfig,
        exclusion_mask: np.ndarray | None = None,
        first_id: int = 1,
    ) -> None:
        problems = config.problems()
        if problems:
            raise ValueError("invalid OccupancyFilterConfig: " + "; ".join(problems))
        self.config, self.exclusion_mask = config, exclusion_mask
        self.next_id = first_id
        self.rng = np.random.default_rng(config.seed)
        self._stamp = np.zeros((1, 1, 1), np.int32)
        self._mark = 0
        self.clear()

    def clear(self) -> None:
        """Forget every filter (ids go on)."""
        n = self.config.particles
        self.ids = np.zeros(0, np.int64)
        self.particles = np.zeros((0, n, 3))
        self.estimates = np.zeros((0, 3))
        self.extents = np.zeros((0, 3))  # each filter's last box size (NaN: none yet)
        self.frames = np.zeros(0, np.int64)
        self.origins = np.zeros((0, 3))  # where each filter started
        self.travel = np.zeros(0)  # farthest its estimate has been from there, on the floor
        self.starved = np.zeros(0, np.int64)
        self.overlapping = np.zeros(0, np.int64)

    def __len__(self) -> int:
        return len(self.ids)

    def step(self, grid: OccupancyGrid) -> FilterStep:
        """One frame: filter the scene (in `grid`'s own array), step every filter, delete,
        initiate."""
        grid = grid.without(self.exclusion_mask, True).opened(self.config.opening, True)
        count = len(self)
        weights = self._weigh(grid) if count else np.zeros((0, self.config.particles))
        mass = weights.mean(axis=1) if count else np.zeros(0)
        estimates, covariances = self._estimate(weights)
        self.estimates = estimates
        self._resample(weights, grid.geometry)
        self.frames += 1
        deleted = self._deletion(mass, grid.geometry)
        away = self.estimates - self.origins
        away[:, grid.geometry.vertical] = 0.0
        self.travel = np.maximum(self.travel, np.linalg.norm(away, axis=1))
        entered = (self.ids.copy(), self.frames.copy(), self.travel.copy())
        found = (  # without initiation the caller boxes its filters itself
            components(grid, self._component_factor(grid.geometry))
            if self.config.initiation
            else Components.none()
        )
        self._drop(deleted)
        started = self._initiate(grid, found)
        return self._report(grid, found, entered, estimates, covariances, mass, deleted, started)

    # -- (a)-(c): propagation, likelihood, blocking --------------------------------------------

    def _weigh(self, grid: OccupancyGrid) -> np.ndarray:
        geometry, config = grid.geometry, self.config
        if self._stamp.shape != geometry.shape:
            self._stamp, self._mark = np.zeros(geometry.shape, np.int32), 0
        cells = geometry.indices(self.particles)
        ranking = config.propagation is Propagation.RANKING
        offsets = _neighbour_offsets(geometry.shape)
        for row in range(len(self)):
            if self._mark >= MAX_STAMP:
                self._stamp[:], self._mark = 0, 0
            self._mark += 1
            _snap_unique(cells[row], self._stamp, self._mark, offsets, grid.dense, ranking)
        self.particles = geometry.centres(cells)
        flat = cells.reshape(-1, 3)
        flat_weights = np.empty(len(flat))
        radius = np.asarray(config.radius, np.int64)
        _surface_weights(flat, grid.dense, radius, config.foreground_factor, flat_weights)
        weights = flat_weights.reshape(len(self), -1)
        if config.blocking and len(self) > 1:
            weights[self._blocked(self.particles, geometry)] = 0.0
        return weights

    def _semi_axes(self, estimates: np.ndarray, geometry: GridGeometry) -> np.ndarray:
        """(M, 3) blocking semi-axes around each filter's estimate."""
        axes = np.tile(np.asarray(self.config.block_axes, dtype=float), (len(estimates), 1))
        height = estimates - np.asarray(geometry.origin)
        axes = np.where(axes > 0, axes, np.maximum(height, 1e-9))
        factor = self.config.block_box_factor
        if factor > 0 and len(self.extents) == len(estimates):
            known = np.isfinite(self.extents) & (self.extents > 0)
            axes = np.where(known, factor * np.where(known, self.extents, 0.0), axes)
        axes[:, np.asarray(geometry.shape) == 1] = np.inf  # a flat axis never separates
        return axes

    def _blocked(self, points: np.ndarray, geometry: GridGeometry) -> np.ndarray:
        """(M, N): particle n of filter j lies inside another filter's blocking shape."""
        axes = self._semi_axes(self.estimates, geometry)
        free_axis = -1 if self.config.block_shape is BlockShape.ELLIPSOID else geometry.vertical
        blocked = np.empty(points.shape[:2], dtype=np.bool_)
        _blocked_particles(points, self.estimates, axes, free_axis, blocked)
        return blocked

    def _inside(self, scaled: np.ndarray, vertical: int) -> np.ndarray:
        """Whether offsets (..., 3), divided by the semi-axes, lie in the blocking shape."""
        squared = scaled**2
        if self.config.block_shape is BlockShape.ELLIPSOID:
            result: np.ndarray = squared.sum(axis=-1) <= 1.0
            return result
        inside: np.ndarray = squared.sum(axis=-1) - squared[..., vertical] <= 1.0
        return inside

    # -- (d), (e): estimate and resampling -----------------------------------------------------

    def _estimate(self, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        totals = weights.sum(axis=1)
        alive = totals > 0
        estimates = self.estimates.copy()
        covariances = np.tile(np.eye(3), (len(self), 1, 1))
        if alive.any():
            w = weights[alive] / totals[alive, None]
            p = self.particles[alive]
            mean = np.einsum("mn,mnk->mk", w, p)
            centred = p - mean[:, None]
            estimates[alive] = mean
            covariances[alive] = np.einsum("mn,mnk,mnl->mkl", w, centred, centred)
        return estimates, covariances

    def _resample(self, weights: np.ndarray, geometry: GridGeometry) -> None:
        count, n = weights.shape
        if not count:
            return
        totals = weights.sum(axis=1, keepdims=True)
        uniform = np.full_like(weights, 1.0 / n)
        normalised = np.divide(weights, totals, out=uniform, where=totals > 0)
        cumulative = np.cumsum(normalised, axis=1)
        cumulative[:, -1] = 1.0
        offsets = (np.arange(n) + self.rng.random((count, 1))) / n
        picked = np.empty_like(self.particles)
        _systematic_picks(cumulative, offsets, self.particles, picked)
        widths = np.tile(jitter_widths(self.config, geometry), (count, 1))
        factor = self.config.jitter_box_factor
        if factor > 0:
            known = np.isfinite(self.extents) & (self.extents > 0)
            widths = np.where(known, factor * np.where(known, self.extents, 0.0), widths)
        self.particles = picked + (self.rng.random(picked.shape) - 0.5) * widths[:, None]

    # -- deletion and initiation ---------------------------------------------------------------

    def _deletion(self, mass: np.ndarray, geometry: GridGeometry) -> np.ndarray:
        config = self.config
        self.starved = np.where(mass < config.starve_weight, self.starved + 1, 0)
        deleted = self.starved >= config.starve_frames
        if len(self) > 1:
            axes = self._semi_axes(self.estimates, geometry)
            scaled = (self.estimates[:, None] - self.estimates[None]) / (
                axes[None] * config.overlap_scale
            )
            inside = self._inside(scaled, geometry.vertical)  # [j, m]: j inside m's
            np.fill_diagonal(inside, False)
            younger = self.ids[:, None] > self.ids[None, :]
            self.overlapping = np.where((inside & younger).any(axis=1), self.overlapping + 1, 0)
            deleted |= self.overlapping >= config.overlap_frames
        return deleted

    def remove(self, rows: np.ndarray) -> None:
        """Delete the filters of `rows` (bool, one per filter): for a caller's own deletion
        rule."""
        if rows.any():
            self._drop(rows)

    def _drop(self, deleted: np.ndarray) -> None:
        keep = ~deleted
        for name in (
            "ids",
            "particles",
            "estimates",
            "extents",
            "frames",
            "origins",
            "travel",
            "starved",
            "overlapping",
        ):
            setattr(self, name, getattr(self, name)[keep])

    def _component_factor(self, geometry: GridGeometry) -> int:
        return max(1, round(self.config.component_cell / min(geometry.cell)))

    def _excluded(self, found: Components, label: int, geometry: GridGeometry) -> bool:
        """A filter is within `exclusion` of blob `label`'s centre of mass, on the floor."""
        apart = found.centroids[label] - self.estimates
        apart[:, geometry.vertical] = 0.0
        return bool(np.linalg.norm(apart, axis=1).min() < self.config.exclusion)

    def _initiate(self, grid: OccupancyGrid, found: Components) -> int:
        config, geometry = self.config, grid.geometry
        if not len(found):  # none without `initiation`
            return 0
        v = geometry.vertical
        people = (found.counts * geometry.cell[0] > config.min_blob) & (
            found.highs[:, v] - found.lows[:, v] >= config.min_height
        )
        started = 0
        for label in np.flatnonzero(people)[np.argsort(-found.counts[people], kind="stable")]:
            if len(self) and self._excluded(found, label, geometry):
                continue
            cells = grid.cells[found.labels == label]
            size = found.highs[label] - found.lows[label]
            self.start(geometry.centres(cells), found.centroids[label], size)
            started += 1
        return started

    def start(self, points: np.ndarray, centre: np.ndarray, extent: np.ndarray) -> int:
        """A new filter at `centre` (3,), its particles drawn from `points` (P > 0, 3) (a
        blob's cells), `extent` (3,) its blob's size; its id."""
        n = self.config.particles
        drawn = points[self.rng.choice(len(points), n, len(points) < n)]
        self.ids = np.append(self.ids, self.next_id)
        self.next_id += 1
        self.particles = np.concatenate([self.particles, drawn[None]])
        self.estimates = np.concatenate([self.estimates, centre[None]])
        self.extents = np.concatenate([self.extents, extent[None]])
        self.origins = np.concatenate([self.origins, centre[None]])
        for name in ("frames", "travel", "starved", "overlapping"):
            setattr(self, name, np.append(getattr(self, name), 0))
        return int(self.ids[-1])

    # -- the report ----------------------------------------------------------------------------

    def _report(
        self,
        grid: OccupancyGrid,
        found: Components,
        entered: tuple[np.ndarray, np.ndarray, np.ndarray],
        estimates: np.ndarray,
        covariances: np.ndarray,
        mass: np.ndarray,
        deleted: np.ndarray,
        started: int,
    ) -> FilterStep:
        ids, frames, travel = entered
        new = slice(len(self) - started, len(self))
        all_estimates = np.concatenate([estimates, self.estimates[new]])
        all_covariances = np.concatenate(
            [covariances, np.array([np.cov(p.T) for p in self.particles[new]]).reshape(-1, 3, 3)]
        )
        lows, highs = self._boxes(grid, found, all_estimates)
        sizes = (highs - lows)[~np.concatenate([deleted, np.zeros(started, bool)])]
        self.extents = np.where(np.isfinite(sizes), sizes, self.extents)
        all_mass = np.concatenate([mass, np.ones(started)])
        measured = (all_mass >= self.config.starve_weight) & np.isfinite(lows[:, 0])
        return FilterStep(
            ids=np.concatenate([ids, self.ids[new]]),
            estimates=all_estimates,
            covariances=all_covariances,
            lows=lows,
            highs=highs,
            mass=all_mass,
            measured=measured,
            deleted=np.concatenate([deleted, np.zeros(started, bool)]),
            started=np.concatenate([np.zeros(len(ids), bool), np.ones(started, bool)]),
            frames=np.concatenate([frames, np.zeros(started, np.int64)]),
            travel=np.concatenate([travel, np.zeros(started)]),
            components=found,
            grid=grid,
        )

    def blob_boxes(
        self, grid: OccupancyGrid, estimates: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per estimate (M, 3), lows / highs (M, 3) of its part of the blob it lies in (NaN:
        none); for a caller that does its own initiation."""
        found = components(grid, self._component_factor(grid.geometry))
        return self._boxes(grid, found, estimates)

    def _boxes(
        self, grid: OccupancyGrid, found: Components, estimates: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Per estimate, the box of its part of the component it lies in (NaN: none)."""
        count = len(estimates)
        lows, highs = np.full((count, 3), np.nan), np.full((count, 3), np.nan)
        if not len(found) or not count:
            return lows, highs
        # the cloud trails a moving person by up to half the jitter: so may its mean
        reach = jitter_widths(self.config, grid.geometry) / 2.0
        inside = (
            (estimates[:, None] >= found.lows[None] - reach)
            & (estimates[:, None] <= found.highs[None] + reach)
        ).all(axis=-1)
        distance = np.linalg.norm(estimates[:, None] - found.centroids[None], axis=-1)
        held = np.any(inside, axis=1)
        owner = np.where(held, np.argmin(np.where(inside, distance, np.inf), axis=1), -1)
        shared = np.bincount(owner[owner >= 0], minlength=len(found))
        for row in np.flatnonzero(owner >= 0):
            label = owner[row]
            if shared[label] == 1:
                lows[row], highs[row] = found.lows[label], found.highs[label]
        split = np.flatnonzero((owner >= 0) & (shared[np.maximum(owner, 0)] > 1))
        if len(split):
            scale = self._semi_axes(estimates, grid.geometry)
            scale[~np.isfinite(scale)] = 1.0
            parts = split_cells(grid.geometry, grid.cells, estimates, scale, found.labels, owner)
            lows[split], highs[split] = parts[0][split], parts[1][split]
        return lows, highs


def split_cells(
    geometry: GridGeometry,
    cells: np.ndarray,
    estimates: np.ndarray,
    scale: np.ndarray,
    labels: np.ndarray | None = None,
    owner: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Bounds (K, 3) lows / highs, world units, of the cells (P, 3) nearest each of `estimates`
    (K, 3), distances divided by `scale` (K, 3) per estimate (NaN: an estimate got none). With
    `labels` (P,) and `owner` (K,), a cell goes only to the estimates that own its label (None:
    every cell and estimate share one)."""
    count = len(estimates)
    cell_lows = np.full((count, 3), np.iinfo(np.int64).max, np.int64)
    cell_highs = np.full((count, 3), -1, np.int64)
    _split_boxes(
        np.asarray(geometry.origin, dtype=float), np.asarray(geometry.cell, dtype=float),
        np.zeros(len(cells), np.int64) if labels is None else labels,
        np.zeros(count, np.int64) if owner is None else owner,
        estimates, scale, cell_lows, cell_highs, cells,
    )  # fmt: skip
    cell, origin = np.asarray(geometry.cell), np.asarray(geometry.origin)
    got = cell_highs[:, :1] >= 0
    lows = np.where(got, origin + cell_lows * cell, np.nan)
    highs = np.where(got, origin + (cell_highs + 1) * cell, np.nan)
    return lows, highs


def _neighbour_offsets(shape: tuple[int, int, int], reach: int = 2) -> np.ndarray:
    """Offsets (K, 3) to the cells within `reach` per axis (none along a flat axis), nearest
    first; ties in a fixed order."""
    spans = [range(-reach, reach + 1) if s > 1 else range(1) for s in shape]
    offsets = np.array([(a, b, c) for a in spans[0] for b in spans[1] for c in spans[2]])
    offsets = offsets[np.any(offsets != 0, axis=1)]
    order = np.argsort((offsets**2).sum(axis=1), kind="stable")
    return np.ascontiguousarray(offsets[order], dtype=np.int64)


@numba.njit(cache=True, nogil=True)
def _snap_unique(  # pragma: no cover
    cells: np.ndarray,
    stamp: np.ndarray,
    mark: int,
    offsets: np.ndarray,
    dense: np.ndarray,
    ranking: bool,
) -> None:
    """Step (a) for one filter: one particle per cell of the grid (cells (N, 3), in place)."""
    nx, ny, nz = dense.shape
    for p in range(cells.shape[0]):
        i, j, k = cells[p, 0], cells[p, 1], cells[p, 2]
        if i < 0 or j < 0 or k < 0 or i >= nx or j >= ny or k >= nz:
            continue  # outside the grid: no data, weight 0 (clipping would pile them on the walls)
        if stamp[i, j, k] == mark:
            chosen = _nearest_free(i, j, k, stamp, mark, offsets, dense, ranking)
            if chosen >= 0:
                i, j, k = i + offsets[chosen, 0], j + offsets[chosen, 1], k + offsets[chosen, 2]
        cells[p, 0], cells[p, 1], cells[p, 2] = i, j, k
        stamp[i, j, k] = mark


@numba.njit(cache=True, nogil=True)
def _nearest_free(  # pragma: no cover
    i: int,
    j: int,
    k: int,
    stamp: np.ndarray,
    mark: int,
    offsets: np.ndarray,
    dense: np.ndarray,
    ranking: bool,
) -> int:
    """Row of `offsets` to the nearest cell around (i, j, k), inside the grid, not yet stamped
    with `mark`; with `ranking`, the nearest such cell that is dense, else the nearest at all.
    -2: every neighbour is outside the grid or taken."""
    nx, ny, nz = dense.shape
    free = -2
    for o in range(offsets.shape[0]):
        a, b, c = i + offsets[o, 0], j + offsets[o, 1], k + offsets[o, 2]
        if a < 0 or b < 0 or c < 0 or a >= nx or b >= ny or c >= nz:
            continue
        if stamp[a, b, c] == mark:
            continue
        if not ranking or dense[a, b, c]:
            return o
        if free == -2:
            free = o
    return free


@numba.njit(cache=True, nogil=True)
def _surface_weights(  # pragma: no cover
    cells: np.ndarray, dense: np.ndarray, radius: np.ndarray, foreground: bool, out: np.ndarray
) -> None:
    """Step (b): eq. 3.8 at every cell of `cells` (P, 3). A particle outside the grid weighs 0;
    a neighbour outside it counts as the nearest cell inside (the floor is not a person's
    surface, nor is the edge of a camera's view)."""
    nx, ny, nz = dense.shape
    rx, ry, rz = radius[0], radius[1], radius[2]
    size = (2 * rx + 1) * (2 * ry + 1) * (2 * rz + 1)
    for p in range(cells.shape[0]):
        i, j, k = cells[p, 0], cells[p, 1], cells[p, 2]
        if i < 0 or j < 0 or k < 0 or i >= nx or j >= ny or k >= nz:
            out[p] = 0.0
            continue
        n1 = 0
        for a in range(i - rx, i + rx + 1):
            ca = min(max(a, 0), nx - 1)
            for b in range(j - ry, j + ry + 1):
                cb = min(max(b, 0), ny - 1)
                for c in range(k - rz, k + rz + 1):
                    n1 += dense[ca, cb, min(max(c, 0), nz - 1)]
        weight = 1.0 - abs(2 * n1 - size) / size
        out[p] = weight * n1 / size if foreground else weight


@numba.njit(cache=True, nogil=True)
def _split_boxes(  # pragma: no cover
    origin: np.ndarray,
    cell: np.ndarray,
    labels: np.ndarray,
    owner: np.ndarray,
    estimates: np.ndarray,
    scale: np.ndarray,
    lows: np.ndarray,
    highs: np.ndarray,
    cells: np.ndarray,
) -> None:
    """Each cell of a component shared by several estimates goes to the nearest (distance
    between the cell's centre and the estimate, scaled by `scale`); lows / highs (M, 3) collect
    each estimate's cell bounds."""
    for p in range(cells.shape[0]):
        best, nearest = -1, np.inf
        for m in range(estimates.shape[0]):
            if owner[m] != labels[p]:
                continue
            d = 0.0
            for axis in range(3):
                centre = origin[axis] + (cells[p, axis] + 0.5) * cell[axis]
                d += ((centre - estimates[m, axis]) / scale[m, axis]) ** 2
            if d < nearest:
                best, nearest = m, d
        if best < 0:
            continue
        for axis in range(3):
            lows[best, axis] = min(lows[best, axis], cells[p, axis])
            highs[best, axis] = max(highs[best, axis], cells[p, axis])


@numba.njit(cache=True, nogil=True)
def _blocked_particles(  # pragma: no cover
    points: np.ndarray, centres: np.ndarray, axes: np.ndarray, free_axis: int, out: np.ndarray
) -> None:
    """Step (c): out[j, n] = particle n of filter j (points (M, N, 3)) lies inside the shape
    around another filter's centre (M, 3) with semi-axes (M, 3): sum over the axes of
    (offset / semi-axis)^2 <= 1, the `free_axis` left out (a cylinder along it; -1: an
    ellipsoid). The sum runs in NumPy's order (x + y + z, then minus the free axis)."""
    count, n = points.shape[0], points.shape[1]
    for j in range(count):
        for p in range(n):
            inside = False
            for m in range(count):
                if m == j:
                    continue
                total, left_out = 0.0, 0.0
                for axis in range(3):
                    scaled = (points[j, p, axis] - centres[m, axis]) / axes[m, axis]
                    total += scaled**2
                    if axis == free_axis:
                        left_out = scaled**2
                if free_axis >= 0:
                    total -= left_out
                if total <= 1.0:
                    inside = True
                    break
            out[j, p] = inside


@numba.njit(cache=True, nogil=True)
def _systematic_picks(  # pragma: no cover
    cumulative: np.ndarray, offsets: np.ndarray, particles: np.ndarray, out: np.ndarray
) -> None:
    """Step (e)'s selection for every filter: out[j, i] = the particle of filter j whose
    cumulative weight (M, N, ending at 1) first reaches offsets[j, i] (increasing)."""
    count, n = cumulative.shape
    for j in range(count):
        chosen = 0
        for i in range(n):
            while chosen < n - 1 and cumulative[j, chosen] < offsets[j, i]:
                chosen += 1
            out[j, i] = particles[j, chosen]
