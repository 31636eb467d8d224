"""Occupancy grids for seed 002's tracker: one code for 2-D masks and 3-D voxel volumes (no rclpy).

A grid is a dense uint8 array of shape (nx, ny, nz) with a cell edge and an origin per axis; a 2-D
foreground mask is a grid one cell deep (nz = 1). World coordinates of cell (i, j, k)'s centre are
`origin + (index + 0.5) * cell` (metres for voxels, REP-103 with z up; scene pixels for masks).
The dense array is what the particle filters query (a 2 cm grid of the thesis's 400 x 500 x
210 cm room is 200 x 250 x 105 = 5.25 M cells, 5.25 MB as uint8); the occupied cells are also
kept as an index list, so the per-frame work (scene filtering, connected components) follows the
occupied cells, not the room.

Scene filtering (digest section 1): an exclusion mask (doors) forces cells to background, and the
morphological opening with a vertical line of `length` cells keeps a cell only when it lies on a
vertical run of at least `length` occupied cells (an opening with a line keeps exactly the runs
that contain the line).

Connected components: 26-connected (8 in 2-D) on a coarse grid of `factor`^3 cells (a 2 cm grid
labelled at 8 cm), each occupied cell taking its coarse cell's label. Blobs closer than one coarse
cell are joined, as a reconstruction's small gaps should be; the labelling costs the coarse grid,
not the fine one.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numba
import numpy as np
from scipy import ndimage

DIMS = 3


@dataclass(frozen=True)
class GridGeometry:
    """Shape (cells per axis), cell edge per axis and origin (world coordinates of the grid's
    corner) of an occupancy grid; `vertical` is the axis people stand along (2 for voxels with z
    up; 1, the image rows, for a mask)."""

    shape: tuple[int, int, int]
    cell: tuple[float, float, float]
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    vertical: int = 2

    def __post_init__(self) -> None:
        if len(self.shape) != DIMS or min(self.shape) < 1:
            raise ValueError(f"a grid needs 3 positive sizes, got {self.shape}")
        if len(self.cell) != DIMS or min(self.cell) <= 0:
            raise ValueError(f"a grid needs 3 positive cell edges, got {self.cell}")
        if self.vertical not in range(DIMS):
            raise ValueError(f"vertical axis {self.vertical} is not 0, 1 or 2")

    @property
    def size(self) -> np.ndarray:
        """Extent of the grid per axis, world units."""
        extent: np.ndarray = np.asarray(self.shape) * np.asarray(self.cell)
        return extent

    def centres(self, indices: np.ndarray) -> np.ndarray:
        """World coordinates (..., 3) of the centres of cells `indices` (..., 3)."""
        flat = np.ascontiguousarray(indices).reshape(-1, DIMS)
        out = np.empty(flat.shape)
        _cell_centres(flat, np.asarray(self.origin, float), np.asarray(self.cell, float), out)
        return out.reshape(np.shape(indices))

    def indices(self, points: np.ndarray) -> np.ndarray:
        """Cell indices (..., 3) int64 holding world `points` (..., 3); may lie outside the grid."""
        scaled = (points - np.asarray(self.origin)) / np.asarray(self.cell)
        cells: np.ndarray = np.floor(scaled).astype(np.int64)
        return cells


class OccupancyGrid:
    """The occupied cells of one frame: `dense` (uint8, `geometry.shape`) and `cells` (P, 3)."""

    def __init__(self, geometry: GridGeometry, cells: np.ndarray, dense: np.ndarray) -> None:
        self.geometry, self.cells, self.dense = geometry, cells, dense

    @cached_property
    def points(self) -> np.ndarray:
        """World coordinates (P, 3) of the occupied cells' centres."""
        return self.geometry.centres(self.cells)

    @classmethod
    def from_cells(cls, geometry: GridGeometry, cells: np.ndarray) -> OccupancyGrid:
        """The grid whose occupied cells are `cells` (P, 3) integer indices; cells outside the
        grid are dropped, repeats count once."""
        cells = np.ascontiguousarray(np.asarray(cells).reshape(-1, DIMS), dtype=np.int64)
        dense = np.zeros(geometry.shape, dtype=np.uint8)
        kept = np.empty(len(cells), dtype=np.bool_)
        _mark_first_occurrences(dense, cells, kept)
        return cls(geometry, cells if kept.all() else cells[kept], dense)

    @classmethod
    def from_mask(cls, mask: np.ndarray, geometry: GridGeometry) -> OccupancyGrid:
        """A 2-D foreground mask (H, W), nonzero = foreground, as a grid of shape (W, H, 1):
        axis 0 the image columns (x), axis 1 the rows (y, the vertical)."""
        mask = np.asarray(mask)
        if mask.ndim != 2 or (*mask.shape[::-1], 1) != geometry.shape:
            raise ValueError(f"mask of shape {mask.shape} for a grid of shape {geometry.shape}")
        dense = np.empty(geometry.shape, np.uint8)
        cells = np.empty((np.count_nonzero(mask), DIMS), np.int64)
        _transpose_mask(mask.view(np.uint8) if mask.dtype == np.bool_ else mask, dense, cells)
        return cls(geometry, cells, dense)

    def without(self, excluded: np.ndarray | None, in_place: bool = False) -> OccupancyGrid:
        """This grid with the cells where `excluded` (same shape, bool) is set cleared (with
        `in_place` in this grid's array: it saves copying the room)."""
        if excluded is None or not len(self.cells):
            return self
        c = self.cells
        drop = excluded[c[:, 0], c[:, 1], c[:, 2]]
        if not drop.any():
            return self
        dense = self.dense if in_place else self.dense.copy()
        gone = c[drop]
        dense[gone[:, 0], gone[:, 1], gone[:, 2]] = 0
        return OccupancyGrid(self.geometry, c[~drop], dense)

    def opened(self, length: int, in_place: bool = False) -> OccupancyGrid:
        """The opening with a vertical line of `length` cells (1 or less: unchanged); with
        `in_place`, in this grid's array."""
        if length <= 1 or not len(self.cells):
            return self
        keep = np.empty(len(self.cells), dtype=np.bool_)
        _vertical_runs(self.dense, self.cells, self.geometry.vertical, length, keep)
        dense = self.dense if in_place else self.dense.copy()
        cells = np.empty_like(self.cells)
        kept = _clear_dropped(dense, self.cells, keep, cells)
        return OccupancyGrid(self.geometry, cells[:kept], dense)


@numba.njit(cache=True, nogil=True)
def _transpose_mask(
    mask: np.ndarray, dense: np.ndarray, cells: np.ndarray
) -> None:  # pragma: no cover
    """dense[x, y, 0] = mask[y, x] != 0, and its set cells listed in C order."""
    p = 0
    for x in range(mask.shape[1]):
        for y in range(mask.shape[0]):
            if mask[y, x] != 0:
                dense[x, y, 0] = 1
                cells[p, 0], cells[p, 1], cells[p, 2] = x, y, 0
                p += 1
            else:
                dense[x, y, 0] = 0


@numba.njit(cache=True, nogil=True)
def _cell_centres(  # pragma: no cover
    indices: np.ndarray, origin: np.ndarray, cell: np.ndarray, out: np.ndarray
) -> None:
    for p in range(indices.shape[0]):
        for axis in range(DIMS):
            out[p, axis] = origin[axis] + (indices[p, axis] + 0.5) * cell[axis]


@numba.njit(cache=True, nogil=True)
def _mark_first_occurrences(  # pragma: no cover
    dense: np.ndarray, cells: np.ndarray, first: np.ndarray
) -> None:
    """Sets every cell in `dense`; first[p]: cells[p] lies in the grid and was not listed
    before p."""
    nx, ny, nz = dense.shape
    for p in range(cells.shape[0]):
        i, j, k = cells[p, 0], cells[p, 1], cells[p, 2]
        if i < 0 or j < 0 or k < 0 or i >= nx or j >= ny or k >= nz:
            first[p] = False
            continue
        first[p] = dense[i, j, k] == 0
        dense[i, j, k] = 1


@numba.njit(cache=True, nogil=True)
def _clear_dropped(  # pragma: no cover
    dense: np.ndarray, cells: np.ndarray, keep: np.ndarray, out: np.ndarray
) -> int:
    """Clears the cells not kept in `dense` and copies the kept ones to `out`; how many."""
    kept = 0
    for p in range(cells.shape[0]):
        if keep[p]:
            out[kept] = cells[p]
            kept += 1
        else:
            dense[cells[p, 0], cells[p, 1], cells[p, 2]] = 0
    return kept


@numba.njit(cache=True, nogil=True)
def _vertical_runs(  # pragma: no cover
    dense: np.ndarray, cells: np.ndarray, axis: int, length: int, keep: np.ndarray
) -> None:
    """keep[p]: cell p lies on a run of at least `length` occupied cells along `axis`."""
    limit = dense.shape[axis]
    for p in range(cells.shape[0]):
        i, j, k = cells[p, 0], cells[p, 1], cells[p, 2]
        run = 1
        for direction in (-1, 1):
            for step in range(1, length):
                if run >= length:
                    break
                a, b, c = i, j, k
                if axis == 0:
                    a = i + direction * step
                    outside = a < 0 or a >= limit
                elif axis == 1:
                    b = j + direction * step
                    outside = b < 0 or b >= limit
                else:
                    c = k + direction * step
                    outside = c < 0 or c >= limit
                if outside or dense[a, b, c] == 0:
                    break
                run += 1
        keep[p] = run >= length


@dataclass(frozen=True)
class Components:
    """Connected components of a grid's occupied cells; per component (C rows): cell `counts`,
    centre of mass `centroids` (C, 3) and bounds `lows` / `highs` (C, 3) in world units (the
    outer faces of the extreme cells); `labels` (P,) gives each occupied cell's component."""

    labels: np.ndarray
    counts: np.ndarray
    centroids: np.ndarray
    lows: np.ndarray
    highs: np.ndarray

    def __len__(self) -> int:
        return len(self.counts)

    @classmethod
    def none(cls) -> Components:
        """No components (a grid without occupied cells, or one not labelled)."""
        empty = np.zeros((0, DIMS))
        return cls(np.zeros(0, np.int64), np.zeros(0, np.int64), empty, empty, empty)


def components(grid: OccupancyGrid, factor: int) -> Components:
    """The 26-connected components of `grid`, labelled on cells of `factor` x the grid's cell."""
    cells, geometry = grid.cells, grid.geometry
    if not len(cells):
        return Components.none()
    factor = max(1, int(factor))
    coarse = np.zeros(tuple(-(-np.asarray(geometry.shape) // factor)), dtype=np.uint8)
    _mark_coarse(cells, factor, coarse)
    labelled, count = ndimage.label(coarse, structure=np.ones((3, 3, 3), dtype=bool))
    labels = np.empty(len(cells), np.int64)
    _coarse_labels(cells, factor, labelled, labels)
    counts = np.zeros(count, np.int64)
    sums = np.zeros((count, DIMS))
    lows = np.zeros((count, DIMS), np.int64)
    highs = np.zeros((count, DIMS), np.int64)
    _component_stats(cells, labels, counts, sums, lows, highs)
    cell, origin = np.asarray(geometry.cell), np.asarray(geometry.origin)
    centroids = origin + (sums / np.maximum(counts, 1)[:, None] + 0.5) * cell
    return Components(labels, counts, centroids, origin + lows * cell, origin + (highs + 1) * cell)


@numba.njit(cache=True, nogil=True)
def _component_stats(  # pragma: no cover
    cells: np.ndarray,
    labels: np.ndarray,
    counts: np.ndarray,
    sums: np.ndarray,
    lows: np.ndarray,
    highs: np.ndarray,
) -> None:
    lows[:] = np.iinfo(np.int64).max
    highs[:] = -1
    for p in range(cells.shape[0]):
        label = labels[p]
        counts[label] += 1
        for axis in range(3):
            value = cells[p, axis]
            sums[label, axis] += value
            lows[label, axis] = min(lows[label, axis], value)
            highs[label, axis] = max(highs[label, axis], value)


@numba.njit(cache=True, nogil=True)
def _mark_coarse(cells: np.ndarray, factor: int, coarse: np.ndarray) -> None:  # pragma: no cover
    for p in range(cells.shape[0]):
        coarse[cells[p, 0] // factor, cells[p, 1] // factor, cells[p, 2] // factor] = 1


@numba.njit(cache=True, nogil=True)
def _coarse_labels(  # pragma: no cover
    cells: np.ndarray, factor: int, labelled: np.ndarray, labels: np.ndarray
) -> None:
    for p in range(cells.shape[0]):
        i, j, k = cells[p, 0] // factor, cells[p, 1] // factor, cells[p, 2] // factor
        labels[p] = labelled[i, j, k] - 1
