"""Benchmark of tracker_filter (area `filter`): the tracker's per-frame update cost.

Run: python bench/bench_filter.py [--quick]   (or `make bench`). Prints a table and writes
out/bench/filter.json. NumPy's BLAS is limited to one thread.

- multi: TrackManager.step (predict, gate, Hungarian assignment, update, confirm, delete,
  initiate, snapshot) with 50 targets + 10 clutter detections per frame in a 1920x1080 scene, after
  a warm-up that confirms the 50 tracks; one row per filter; target <= 1 ms per frame (median).
  The same step with one filterpy object per track (ObjectBank, the plug-in path for filters
  without a vectorised bank) shows why the vectorised bank exists.
- messages: converting that frame's TrackSet to a tracker_msgs/TrackArray (node side).
- scaling: the multi tracker (kalman_cv) beside a SORT-like loop (one filterpy KalmanFilter per
  track, Euclidean cost, scipy's Hungarian with a distance gate: the usual Python baseline) at 1
  target and at 200 targets + 40 clutter, and the multi tracker with 50 targets and 0-450 clutter
  detections (time per detection should not grow). Targets (issue 16): <= 1x the SORT-like loop
  at 1 target, >= 8x faster at 200 + 40.
- single: the seed's single-target mode (preset seed000 / seed000_kalman, largest of 3 blobs) per
  frame, and one filter's predict + update alone.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from timing import machine, summary, write_results  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
for _pkg in ("tracker_msgs", "tracker_filter"):
    sys.path.insert(0, str(ROOT / "src" / _pkg))

from tracker_filter.filters import PerTrackFactory  # noqa: E402
from tracker_filter.gated_hungarian.config import TrackerConfig  # noqa: E402
from tracker_filter.management import TrackManager  # noqa: E402
from tracker_filter.observation import Detections, Observation  # noqa: E402
from tracker_filter.synthetic import bouncing_scene  # noqa: E402
from tracker_filter.tracking import TrackStatus  # noqa: E402

OUT = ROOT / "out" / "bench" / "filter.json"
TARGET_MS = 1.0
FILTERS = ("kalman_cv", "kalman_ca", "alpha_beta", "alpha_beta_gamma")


def timed_steps(tracker, frames, warmup: int) -> tuple[list[float], list]:
    """Milliseconds per step after `warmup` frames, and the TrackSets of the timed frames."""
    times, outputs = [], []
    for k, frame in enumerate(frames):
        start = time.perf_counter()
        tracks = tracker.step(Observation(frame.time, frame.detections))
        elapsed = time.perf_counter() - start
        if k >= warmup:
            times.append(1e3 * elapsed)
            outputs.append(tracks)
    return times, outputs


def bench_multi(quick: bool) -> tuple[dict, list]:
    warmup, measured = 30, (60 if quick else 400)
    frames = bouncing_scene(
        np.random.default_rng(0), targets=50, clutter=10, frames=warmup + measured
    )
    rows = {}
    last_outputs = []
    for kind in FILTERS:
        tracker = TrackerConfig.preset("multi", filter=kind).build_tracker()
        times, outputs = timed_steps(tracker, frames, warmup)
        confirmed = [
            int(np.isin(o.status, (TrackStatus.CONFIRMED, TrackStatus.COASTING)).sum())
            for o in outputs
        ]
        rows[kind] = summary(times) | {
            "tracks_per_frame": statistics.fmean(len(o) for o in outputs),
            "confirmed_per_frame": statistics.fmean(confirmed),
            "meets_target": statistics.median(times) <= TARGET_MS,
        }
        if kind == "kalman_cv":
            last_outputs = outputs
    config = TrackerConfig.preset("multi")
    reference = config.build_tracker()
    per_track = TrackManager(
        PerTrackFactory(config.filter),
        reference.associator,
        reference.initiator,
        reference.confirmation,
        reference.deleter,
    )
    short = frames[: warmup + min(measured, 60)]
    times, outputs = timed_steps(per_track, short, warmup)
    rows["kalman_cv_per_track_filterpy"] = summary(times) | {
        "tracks_per_frame": statistics.fmean(len(o) for o in outputs)
    }
    return rows, last_outputs


class SortLike:
    """The SORT-like peer: per-track filterpy Kalman filters (constant velocity), nearest
    assignment by Euclidean distance within `gate_px`, new tracks from unmatched detections,
    deletion after `max_misses`. Timed only; not part of the suite."""

    def __init__(self, gate_px: float = 60.0, max_misses: int = 12) -> None:
        from filterpy.kalman import KalmanFilter
        from scipy.optimize import linear_sum_assignment
        from scipy.spatial.distance import cdist

        self._kalman, self._assign, self._distances = KalmanFilter, linear_sum_assignment, cdist
        self.gate, self.max_misses = gate_px, max_misses
        self.tracks: list = []  # [filter, misses]
        self.time: float | None = None

    def _new(self, position: np.ndarray):  # noqa: ANN202 - a filterpy KalmanFilter
        kf = self._kalman(dim_x=4, dim_z=2)
        kf.x = np.array([position[0], position[1], 0.0, 0.0])
        kf.H = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])
        kf.P *= 100.0
        kf.R *= 4.0
        return kf

    def step(self, t: float, positions: np.ndarray) -> int:
        dt = 0.0 if self.time is None else t - self.time
        self.time = t
        for kf, _ in self.tracks:
            kf.F = np.array([[1.0, 0, dt, 0], [0, 1.0, 0, dt], [0, 0, 1.0, 0], [0, 0, 0, 1.0]])
            kf.Q = np.eye(4) * 10.0 * max(dt, 1e-3)
            kf.predict()
        matched_tracks: set[int] = set()
        matched_detections: set[int] = set()
        if self.tracks and len(positions):
            predicted = np.array([kf.x[:2] for kf, _ in self.tracks])
            cost = self._distances(predicted, positions)
            rows, cols = self._assign(np.where(cost > self.gate, 1e6, cost))
            for r, c in zip(rows, cols, strict=True):
                if cost[r, c] <= self.gate:
                    self.tracks[r][0].update(positions[c])
                    matched_tracks.add(int(r))
                    matched_detections.add(int(c))
        for k, track in enumerate(self.tracks):
            track[1] = 0 if k in matched_tracks else track[1] + 1
        self.tracks = [track for track in self.tracks if track[1] <= self.max_misses]
        for c in range(len(positions)):
            if c not in matched_detections:
                self.tracks.append([self._new(positions[c]), 0])
        return len(self.tracks)


def bench_scaling(quick: bool) -> dict:
    warmup, measured = 20, (30 if quick else 150)
    rows = {}
    for targets, clutter in ((1, 0), (200, 40)):
        frames = bouncing_scene(
            np.random.default_rng(2), targets=targets, clutter=clutter, frames=warmup + measured
        )
        # room for every target and the clutter's tentative tracks (the preset keeps 100)
        ours = TrackerConfig.preset("multi", filter="kalman_cv", max_tracks=2000).build_tracker()
        times, outputs = timed_steps(ours, frames, warmup)
        peer = SortLike()
        peer_times = []
        for k, frame in enumerate(frames):
            start = time.perf_counter()
            peer.step(frame.time, frame.detections.positions)
            if k >= warmup:
                peer_times.append(1e3 * (time.perf_counter() - start))
        label = f"{targets}_targets_{clutter}_clutter"
        rows[f"multi_{label}"] = summary(times) | {
            "tracks_per_frame": statistics.fmean(len(o) for o in outputs)
        }
        rows[f"sort_like_{label}"] = summary(peer_times) | {"tracks_per_frame": len(peer.tracks)}
        rows[f"speedup_{label}"] = {
            "sort_like_over_multi": statistics.median(peer_times) / statistics.median(times)
        }
    for clutter in (0, 50, 150, 300, 450):
        frames = bouncing_scene(
            np.random.default_rng(3), targets=50, clutter=clutter, frames=warmup + measured
        )
        ours = TrackerConfig.preset("multi", filter="kalman_cv").build_tracker()
        times, outputs = timed_steps(ours, frames, warmup)
        detections = 50 + clutter
        rows[f"multi_50_targets_{clutter}_clutter"] = summary(times) | {
            "tracks_per_frame": statistics.fmean(len(o) for o in outputs),
            "us_per_detection": 1e3 * statistics.median(times) / detections,
        }
    return rows


def bench_messages(outputs: list, quick: bool) -> dict:
    try:
        from std_msgs.msg import Header

        from tracker_filter.tracker_node import tracks_to_msg
    except ImportError as error:  # no ROS in this environment
        return {"skipped": str(error)}
    header = Header(frame_id="scene")
    sample = outputs[: 20 if quick else 100]
    times = []
    for tracks in sample:
        start = time.perf_counter()
        tracks_to_msg(tracks, header)
        times.append(1e3 * (time.perf_counter() - start))
    return summary(times) | {"tracks_per_frame": statistics.fmean(len(t) for t in sample)}


def bench_single(quick: bool) -> dict:
    rng = np.random.default_rng(1)
    count = 200 if quick else 2000
    rows = {}
    for preset in ("seed000", "seed000_kalman"):
        tracker = TrackerConfig.preset(preset).build_tracker()
        times = []
        for k in range(count):
            centre = np.array([160.0 + 40.0 * np.sin(k / 30.0), 120.0]) + rng.normal(size=2)
            blobs = np.array([centre, rng.uniform(0, 320, 2), rng.uniform(0, 240, 2)])
            detections = Detections(
                blobs,
                [400.0, 30.0, 20.0],
                np.column_stack([blobs - 5, np.full((3, 2), 10.0)]),
                np.zeros(3),
            )
            start = time.perf_counter()
            tracker.step(Observation(k * 0.12, detections))
            times.append(1e3 * (time.perf_counter() - start))
        rows[f"{preset}_tracker_step"] = summary(times[10:])
    for kind in FILTERS:
        f = TrackerConfig.preset("multi", filter=kind).filter.new_filter(
            np.array([160.0, 120.0]), 0.0
        )
        z = np.array([161.0, 120.5])
        times = []
        for k in range(1, count):
            start = time.perf_counter()
            f.predict(k * 0.12)
            f.update(z + k)
            times.append(1e3 * (time.perf_counter() - start))
        rows[f"{kind}_filter_predict_update"] = summary(times)
    return rows


def print_table(title: str, rows: dict) -> None:
    print(f"\n{title}")
    print(f"  {'case':40s} {'median ms':>10s} {'p95 ms':>8s} {'tracks':>7s}")
    for name, row in rows.items():
        if "median_ms" not in row:
            print(f"  {name:40s} {row}")
            continue
        if "us_per_detection" in row:
            name = f"{name} ({row['us_per_detection']:.1f} us/det)"
        tracks = f"{row['tracks_per_frame']:.1f}" if "tracks_per_frame" in row else ""
        flag = (
            ""
            if "meets_target" not in row
            else ("  ok" if row["meets_target"] else "  OVER TARGET")
        )
        print(f"  {name:40s} {row['median_ms']:10.3f} {row['p95_ms']:8.3f} {tracks:>7s}{flag}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repetitions (smoke run)")
    args = parser.parse_args()
    multi, outputs = bench_multi(args.quick)
    results = {
        "area": "filter",
        "machine": machine(),
        "target_ms": TARGET_MS,
        "multi_50_targets_10_clutter": multi,
        "track_array_message": bench_messages(outputs, args.quick),
        "single_target": bench_single(args.quick),
        "scaling": bench_scaling(args.quick),
    }
    print_table(
        f"multi-target step, 50 targets + 10 clutter per frame (target <= {TARGET_MS} ms)", multi
    )
    print_table(
        "TrackSet -> TrackArray message (node side)",
        {"tracks_to_msg": results["track_array_message"]},
    )
    print_table("single target", results["single_target"])
    print_table("scaling: multi tracker vs a SORT-like loop; clutter", results["scaling"])
    write_results(OUT, results, ROOT)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
