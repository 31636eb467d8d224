"""Scores of a recorded run against MOTChallenge ground truth (no rclpy).

CLEAR MOT (MOTA, MOTP, id switches) and IDF1 via `metrics`, for the objects inside the camera
view (what the camera could see) and for the whole scene, plus the pan-tilt figures: share of
frames (after the first lock) with the followed object inside the view, and its centring error.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict
from pathlib import Path

from tracker_msgs_py.geometry import Rect
from tracker_ptz_sim.evaluation import metrics, run_report


def windows_and_targets(
    frames: dict[int, run_report.FrameRecord],
) -> tuple[dict[int, Rect], dict[int, tuple[float, float]]]:
    """Camera window and locked target position per MOTChallenge frame number."""
    numbers = run_report.frame_numbers(frames)
    windows, targets = {}, {}
    for stamp, record in frames.items():
        number = numbers[stamp]
        if record.state is not None:
            w = record.state.window
            windows[number] = Rect(w.x, w.y, w.width, w.height)
        if record.target is not None and record.target.locked:
            targets[number] = (record.target.track.x, record.target.track.y)
    return windows, targets


def score(bag: Path, gt: Path, out: Path) -> dict:
    """Scores of a recorded run against ground truth; also writes tracks.txt and evaluation.json."""
    frames = run_report.collect(bag)
    run_report.write_mot(frames, out / "tracks.txt")
    truth = metrics.load_mot(gt)
    hypotheses = metrics.load_mot(out / "tracks.txt")
    windows, targets = windows_and_targets(frames)
    numbers = sorted(windows)
    result = {
        "frames": len(numbers),
        "in_view": asdict(metrics.clear_mot(metrics.in_view(truth, windows), hypotheses, numbers)),
        "whole_scene": asdict(metrics.clear_mot(truth, hypotheses, numbers)),
        "follow": asdict(metrics.follow_scores(truth, windows, targets)),
    }
    (out / "evaluation.json").write_text(json.dumps(result, indent=2, default=_json_number) + "\n")
    return result


def _json_number(value: object) -> object:
    return None if isinstance(value, float) and math.isnan(value) else value


def format_scores(result: dict) -> str:
    rows = [("frames", str(result["frames"]))]
    for name in ("in_view", "whole_scene"):
        s = result[name]
        rows.append(
            (
                f"CLEAR MOT ({name.replace('_', ' ')})",
                f"MOTA {s['mota']:.3f}  MOTP {s['motp']:.3f}  IDF1 {s['idf1']:.3f}  "
                f"id switches {s['id_switches']}  recall {s['recall']:.3f}  precision {s['precision']:.3f}",
            )
        )
    follow = result["follow"]
    if follow["followed_id"] is None:
        rows.append(("followed object", "none (the camera never locked onto an object)"))
    else:
        rows += [
            (
                "followed object",
                f"id {follow['followed_id']}, first lock at frame {follow['first_lock_frame']}",
            ),
            (
                "inside the view",
                f"{100 * follow['inside_share']:.1f} % of {follow['frames_after_lock']} frames",
            ),
            (
                "centring error",
                f"{follow['mean_center_error_px']:.1f} px "
                f"({100 * follow['mean_center_error_share']:.1f} % of view width)",
            ),
        ]
    width = max(len(n) for n, _ in rows)
    return "\n".join(f"  {n:<{width}}  {v}" for n, v in rows)
