"""Benchmark of seed 002 (area `voxels`): the per-person particle filters' frame step.

Run: python bench/bench_voxels.py [--quick]   (or `make bench`). Prints a table and writes
out/bench/voxels.json. One core (BLAS and numba limited to one thread).

- 3-D: a synthetic voxel room (`simulation.voxel_scenes`: the thesis's 400 x 500 x 210 cm at
  2 cm, 200 x 250 x 105 cells, 6 people, holes, salt noise, a chair and a jacket), 300 particles
  per person; per frame the grid built from the occupied voxel list and the whole step (door
  mask, vertical opening, components, propagation, likelihood, blocking, estimate, resampling,
  deletion, initiation). Target <= 15 ms (the thesis: not real time).
- 2-D: the `occupancy_particles` tracker on a 264 x 264 px motion mask with three people
  walking to and fro across it (and their three blobs; two of them overlap as they pass), 300
  particles each. Target <= 3 ms.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from timing import machine, summary, write_results  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
for _pkg in ("tracker_msgs", "tracker_filter", "tracker_ptz_sim"):
    sys.path.insert(0, str(ROOT / "src" / _pkg))

from tracker_filter.observation import Detections, Observation  # noqa: E402
from tracker_filter.occupancy.occupancy_grid import GridGeometry, OccupancyGrid  # noqa: E402
from tracker_filter.occupancy.occupancy_particles import (  # noqa: E402
    OccupancyFilterConfig,
    OccupancyParticleFilters,
)
from tracker_filter.occupancy.occupancy_tracker import METHOD  # noqa: E402
from tracker_msgs_py.geometry import Rect  # noqa: E402
from tracker_ptz_sim.simulation.voxel_scenes import (  # noqa: E402
    VoxelSceneConfig,
    grid_shape,
    voxel_scene,
)

OUT = ROOT / "out" / "bench" / "voxels.json"
VOXEL_TARGET_MS = 15.0
MASK_TARGET_MS = 3.0
VIEW = 264


def voxel_times(frames: int) -> tuple[list[float], list[float], int]:
    """Per frame: the grid from the voxel list, and grid + step (ms); the filters at the end."""
    scene = VoxelSceneConfig(people=6, frames=frames, seed=5)
    geometry = GridGeometry(grid_shape(scene.voxel_size), (scene.voxel_size,) * 3)
    filters = OccupancyParticleFilters(OccupancyFilterConfig(particles=300))
    grids, steps = [], []
    for k, frame in enumerate(voxel_scene(scene)):
        t0 = time.perf_counter()
        grid = OccupancyGrid.from_cells(geometry, frame.voxels)
        t1 = time.perf_counter()
        filters.step(grid)
        t2 = time.perf_counter()
        if k >= 5:  # after the filters started (and numba's first calls)
            grids.append(1e3 * (t1 - t0))
            steps.append(1e3 * (t2 - t0))
    return grids, steps, len(filters)


def _bounce(x: float, limit: int) -> int:
    """x folded into [0, limit]: a walker who turns back at either edge."""
    period = 2 * limit
    x = x % period
    return int(x if x <= limit else period - x)


def mask_times(frames: int) -> list[float]:
    tracker = METHOD.build(METHOD.defaults(), 1)
    window = Rect(0.0, 0.0, float(VIEW), float(VIEW))
    times = []
    for k in range(frames):
        mask = np.zeros((VIEW, VIEW), np.uint8)
        boxes = []
        for x0, y0, speed in ((10, 40, 3), (200, 120, -4), (60, 150, 2)):
            x = _bounce(x0 + speed * k, VIEW - 30)  # walkers turn at the view's edges
            mask[y0 : y0 + 90, x : x + 30] = 1
            boxes.append((x, y0, 30, 90))
        blobs = np.array(boxes, dtype=float)
        found = Detections(
            blobs[:, :2] + blobs[:, 2:] / 2, blobs[:, 2] * blobs[:, 3], blobs, [1.0] * 3
        )
        t0 = time.perf_counter()
        tracker.step(Observation(0.1 * k, found, mask=mask, window=window))
        if k >= 5:
            times.append(1e3 * (time.perf_counter() - t0))
    return times


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer frames (smoke run)")
    args = parser.parse_args()
    grids, steps, filters = voxel_times(40 if args.quick else 150)
    masks = mask_times(40 if args.quick else 200)
    rows = {
        "3-D: grid from the voxel list (2 cm room)": summary(grids),
        "3-D: grid + step, 6 people x 300 particles, 2 cm": summary(steps)
        | {"meets_target": statistics.median(steps) <= VOXEL_TARGET_MS, "filters": filters},
        "2-D: occupancy_particles step, 264 px mask, 3 people": summary(masks)
        | {"meets_target": statistics.median(masks) <= MASK_TARGET_MS},
    }
    print(f"{'what':<58} {'median':>8} {'p95':>8}")
    for name, row in rows.items():
        print(f"{name:<58} {row['median_ms']:>6.2f}ms {row['p95_ms']:>6.2f}ms")
    write_results(OUT, {"machine": machine(), "results": rows}, ROOT)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
