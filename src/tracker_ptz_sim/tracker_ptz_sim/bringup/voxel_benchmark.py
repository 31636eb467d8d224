"""voxel_benchmark: seed 002's tables rebuilt on synthetic voxel scenes (no rclpy).

Runs the per-person particle filters (`tracker_filter.occupancy.occupancy_particles`) on the synthetic
rooms of `simulation.voxel_scenes` (the thesis's 400 x 500 x 210 cm room, 2-6 people with forced
crossings and long contacts, holes, salt noise, a chair and a jacket) and scores them with CLEAR MOT
as Bernardin 2006: a match within 500 mm, MOTP in mm, miss / false positive / mismatch rates over
the sum of true people, MOTA = 1 - their sum. A filter is reported from its `confirm_frames`-th
frame. "Contacts kept" counts the two people of every contact (horizontal centroids closer than
0.6 m) whose matched filter after it is the one before it (within 3 frames).

Tables: particles 50 / 100 / 150 / 300 / 600 / 1000 at 2 cm (the thesis's Table 4.4); voxel edge
2 / 3 / 4 cm at 300 particles; blocking off; the thesis's rejected variants (ranking propagation,
expanded jitter, f = n1 / |C|). Writes out/voxel_benchmark/results.json.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from tracker_filter.occupancy.occupancy_grid import GridGeometry, OccupancyGrid
from tracker_filter.occupancy.occupancy_particles import (
    BlockShape,
    Jitter,
    OccupancyFilterConfig,
    OccupancyParticleFilters,
    Propagation,
)
from tracker_filter.voxel_tracking import reported_filters
from tracker_msgs_py import stop_signals
from tracker_ptz_sim.evaluation.set_metrics import Points, PointScores, score_points
from tracker_ptz_sim.simulation.voxel_scenes import (
    ROOM_SIZE_M,
    VoxelSceneConfig,
    contact_intervals,
    grid_shape,
    voxel_scene,
)

MATCH_M = 0.5  # Bernardin 2006's threshold
CONFIRM_FRAMES = 3
CONFIRM_TRAVEL_M = 0.3
REACQUIRE_FRAMES = 3
#: (people, seed) of the scenes every row is scored on; 10 s each at 25 fps
SCENES = ((2, 1), (3, 2), (4, 3), (5, 4), (6, 5), (6, 6))
THESIS_TABLE_4_4 = {  # particles: MOTP mm, miss, fp, mme, MOTA (digest section 2)
    50: (222, 0.225, 0.183, 0.493, 0.099),
    100: (206, 0.100, 0.169, 0.081, 0.650),
    150: (193, 0.193, 0.044, 0.014, 0.749),
    300: (187, 0.046, 0.129, 0.011, 0.814),
    600: (185, 0.033, 0.146, 0.009, 0.812),
    1000: (188, 0.043, 0.147, 0.010, 0.800),
}
THESIS_VOXEL_MOTA = {0.02: 0.814, 0.03: 0.777, 0.04: 0.665}


@dataclass(frozen=True)
class Row:
    """One configuration scored over every scene (pooled CLEAR MOT)."""

    name: str
    mota: float
    motp_mm: float
    miss: float
    false_positives: float
    mismatches: float
    id_switches: int
    contacts_kept: int
    contact_people: int
    ms_per_frame: float
    frames: int


def run_scene(
    scene: VoxelSceneConfig,
    config: OccupancyFilterConfig,
    confirm_frames: int = CONFIRM_FRAMES,
    confirm_travel: float = CONFIRM_TRAVEL_M,
) -> tuple[list[Points], list[Points], float]:
    """Truth and reported estimates per frame, and the tracking's mean ms per frame."""
    geometry = GridGeometry(grid_shape(scene.voxel_size), (scene.voxel_size,) * 3)
    filters = OccupancyParticleFilters(config)
    truth: list[Points] = []
    estimates: list[Points] = []
    spent = 0.0
    for frame in voxel_scene(scene):
        with stop_signals.interruptible():
            start = time.perf_counter()
            step = filters.step(OccupancyGrid.from_cells(geometry, frame.voxels))
            spent += time.perf_counter() - start
        reported = reported_filters(step, confirm_frames, confirm_travel)
        truth.append(dict(zip(frame.truth_ids.tolist(), frame.truth_centroids, strict=True)))
        estimates.append(
            dict(zip(step.ids[reported].tolist(), step.estimates[reported], strict=True))
        )
    return truth, estimates, 1000.0 * spent / max(scene.frames, 1)


def contacts(scene: VoxelSceneConfig) -> list[tuple[int, int, int]]:
    """(person, first frame, last frame) of both people of every contact."""
    return [(p, a0, a1) for a, b, a0, a1 in contact_intervals(scene) for p in (a, b)]


def score(name: str, config: OccupancyFilterConfig, voxel: float, frames: int) -> Row:
    """`config` on every scene of SCENES at `voxel` m, pooled."""
    truth: list[Points] = []
    estimates: list[Points] = []
    occlusions: list[tuple[int, int, int]] = []
    times = []
    for people, seed in SCENES:
        scene = VoxelSceneConfig(people=people, frames=frames, voxel_size=voxel, seed=seed)
        offset, base = len(truth), 1000 * seed  # ids kept apart between scenes
        t, e, ms = run_scene(scene, replace(config, seed=seed))
        truth += [{base + i: p for i, p in f.items()} for f in t]
        estimates += [{base + i: p for i, p in f.items()} for f in e]
        occlusions += [(base + p, offset + a, offset + b) for p, a, b in contacts(scene)]
        times.append(ms)
    scores: PointScores = score_points(
        truth, estimates, MATCH_M, MATCH_M, occlusions, REACQUIRE_FRAMES
    )
    objects = max(scores.objects, 1)
    return Row(
        name=name,
        mota=scores.mota,
        motp_mm=1000.0 * scores.motp,
        miss=scores.misses / objects,
        false_positives=scores.false_positives / objects,
        mismatches=scores.id_switches / objects,
        id_switches=scores.id_switches,
        contacts_kept=scores.occlusions - scores.missed_occlusions,
        contact_people=scores.occlusions,
        ms_per_frame=float(np.mean(times)),
        frames=scores.frames,
    )


def configurations(quick: bool) -> list[tuple[str, OccupancyFilterConfig, float]]:
    base = OccupancyFilterConfig()
    counts = (100, 300) if quick else tuple(THESIS_TABLE_4_4)
    rows = [(f"N = {n}, 2 cm", replace(base, particles=n), 0.02) for n in counts]
    rows += [
        (f"N = 300, {round(v * 100)} cm", base, v) for v in ((0.04,) if quick else (0.03, 0.04))
    ]
    rows += [("N = 300, 2 cm, blocking off", replace(base, blocking=False), 0.02)]
    ellipsoid = replace(base, block_shape=BlockShape.ELLIPSOID)
    rows += [("N = 300, 2 cm, the thesis's blocking ellipsoid", ellipsoid, 0.02)]
    if not quick:
        rows += [
            ("ranking propagation", replace(base, propagation=Propagation.RANKING), 0.02),
            ("expanded jitter", replace(base, jitter=Jitter.EXPANDED), 0.02),
            ("f = n1 / size of C", replace(base, foreground_factor=True), 0.02),
        ]
    return rows


def table(rows: list[Row]) -> str:
    lines = [
        "| configuration | MOTA | MOTP (mm) | miss | fp | mme | id switches | contacts kept | ms/frame |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r.name} | {r.mota:.3f} | {r.motp_mm:.0f} | {100 * r.miss:.1f} % | "
            f"{100 * r.false_positives:.1f} % | {100 * r.mismatches:.2f} % | {r.id_switches} | "
            f"{r.contacts_kept} / {r.contact_people} | {r.ms_per_frame:.1f} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=250, help="frames per scene (25 fps)")
    parser.add_argument("--quick", action="store_true", help="fewer rows (N 100 / 300, 4 cm)")
    parser.add_argument("--out", type=Path, default=Path("out/voxel_benchmark"))
    args = parser.parse_args(argv)
    print(
        f"room {ROOM_SIZE_M} m, scenes (people, seed) {SCENES}, {args.frames} frames each",
        flush=True,
    )
    rows = []
    try:
        for name, config, voxel in configurations(args.quick):
            rows.append(score(name, config, voxel, args.frames))
            r = rows[-1]
            print(f"  {name}: MOTA {r.mota:.3f}, {r.ms_per_frame:.1f} ms/frame", flush=True)
    except KeyboardInterrupt:
        print(f"Interrupted after {len(rows)} rows: the table is partial.")
        print(table(rows))
        return stop_signals.INTERRUPTED_EXIT_CODE
    print(table(rows))
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "results.json").write_text(json.dumps([asdict(r) for r in rows], indent=1))
    print(f"wrote {args.out / 'results.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
