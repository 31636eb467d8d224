"""Plots of a run against its ground truth (no rclpy): per-frame centring error, pan, tilt and zoom, and
which track / ground-truth object the camera followed over time, in one PNG."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only: no display on robots and CI machines
import matplotlib.pyplot as plt  # noqa: E402 - after choosing the backend

from tracker_ptz_sim.evaluation.metrics import Boxes, centre_distance  # noqa: E402
from tracker_ptz_sim.evaluation.scoring import RunTrace, followed_objects  # noqa: E402


def plot_run(trace: RunTrace, truth: Boxes, path: Path, title: str = "") -> Path:
    """Write the run's plots to `path` (PNG) and return it."""
    frames = sorted(trace.windows)
    seconds = [(f - 1) / trace.fps for f in frames]
    followed = followed_objects(truth, trace.targets)
    figure, (error_axis, angle_axis, id_axis) = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    error_axis.plot(seconds, [_centring_error(trace, truth, followed, f) for f in frames], lw=1)
    error_axis.set_ylabel("centring error [px]")
    error_axis.set_title(title or "run against ground truth")
    pans = [trace.pan_tilt.get(f, (math.nan, math.nan)) for f in frames]
    angle_axis.plot(seconds, [p for p, _ in pans], label="pan", lw=1)
    angle_axis.plot(seconds, [t for _, t in pans], label="tilt", lw=1)
    angle_axis.set_ylabel("angle [rad]")
    zoom_axis = angle_axis.twinx()
    zoom_axis.plot(
        seconds, [trace.zooms.get(f, math.nan) for f in frames], "k--", lw=1, label="zoom"
    )
    zoom_axis.set_ylabel("zoom")
    handles = angle_axis.get_legend_handles_labels()
    zoom_handles = zoom_axis.get_legend_handles_labels()
    angle_axis.legend(handles[0] + zoom_handles[0], handles[1] + zoom_handles[1], loc="upper right")
    id_axis.plot(
        seconds, [trace.target_ids.get(f, math.nan) for f in frames], ".", ms=3, label="track id"
    )
    id_axis.plot(
        seconds, [followed.get(f, math.nan) for f in frames], "x", ms=3, label="object under it"
    )
    id_axis.set_ylabel("followed")
    id_axis.set_xlabel("time [s]")
    id_axis.legend(loc="upper right")
    figure.tight_layout()
    figure.savefig(path, dpi=90)
    plt.close(figure)
    return path


def _centring_error(trace: RunTrace, truth: Boxes, followed: dict[int, int], frame: int) -> float:
    """The followed object's distance from the view centre; NaN when no object is followed."""
    if frame not in followed:
        return math.nan
    return centre_distance(truth[frame][followed[frame]], trace.windows[frame])
