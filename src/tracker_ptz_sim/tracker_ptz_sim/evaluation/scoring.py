"""Scores of a run against MOTChallenge ground truth (no rclpy), whichever way it ran.

A run, from the graph's bag (`trace_from_frames`) or the in-process pipeline (`trace_from_steps`),
becomes a `RunTrace`: per MOTChallenge frame number the camera window and pose, the observed track
boxes and the locked target. `score_trace` then gives
- CLEAR MOT, IDF1 and HOTA at IoU >= 0.5 for the objects inside the camera view and over the
  whole scene. In view, given the scene's label images (`label_of`), an object counts when at least half
  of its visible pixels are in the image, its box is the tight box of those pixels, and an object
  shown only in part is ignored (`metrics.visible_in_view`); without masks, the objects whose box
  centre is in the view, their boxes clipped to it;
- the pan-tilt figures (`PanTiltScores`): share of locked frames whose target lies on a real object,
  how often the followed object changes (and how often without a reason: it neither left -- is no
  longer among the counted objects, or is leaving: out of them within `EXIT_GRACE_S` of the change
  and for `REASON_GAP_S` after -- nor was lost for `REASON_GAP_S`), centring error, time to the
  first lock and to re-acquire after a loss;
- on request (`centres`), seed 004's scores on box centres for small objects
  (`centre_scores`: OSPA with c = 5 and 10 px, CLEAR MOT with a 10 px match), over the whole scene.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from tracker_filter.tracking import TrackStatus
from tracker_msgs_py.codec import msg_to_rect
from tracker_msgs_py.geometry import Rect
from tracker_msgs_py.labels import ANY_LABEL, MOTION, label_of, wanted
from tracker_ptz_sim.evaluation import centre_scores, error_classes, metrics, run_report
from tracker_ptz_sim.evaluation.metrics import Boxes

LabelImages = Callable[[int], np.ndarray]  # 1-based frame -> label image (pixel = object id)
REASON_GAP_S = 2.0  # a lock lost this long may move on to another object
#: An object out of the counted ones this soon after the change, for REASON_GAP_S, was leaving: a
#: person walking out at the scene's edge is counted down to a quarter of them in it, and moving
#: on a frame or two before that sliver goes is not changing whom the camera follows.
EXIT_GRACE_S = 0.5


@dataclass
class RunTrace:
    """What a run did, per MOTChallenge frame number (from 1)."""

    fps: float
    windows: dict[int, Rect] = field(default_factory=dict)  # scene px
    pan_tilt: dict[int, tuple[float, float]] = field(default_factory=dict)  # rad
    zooms: dict[int, float] = field(default_factory=dict)  # magnification (1: the nominal view)
    hypotheses: Boxes = field(default_factory=dict)  # observed confirmed tracks it follows
    labels: dict[int, str] = field(default_factory=dict)  # their class labels, by track id
    targets: dict[int, tuple[float, float]] = field(default_factory=dict)  # locked target
    target_ids: dict[int, int] = field(default_factory=dict)  # locked track id
    detections: dict[int, list[Rect]] = field(default_factory=dict)  # the detector's boxes
    tentative: dict[int, list[Rect]] = field(default_factory=dict)  # updated tentative tracks

    def write_mot(self, path: Path) -> int:
        """The observed tracks in MOTChallenge format; how many rows."""
        rows = [
            metrics.mot_row(frame, i, b, label=self.labels.get(i, MOTION))
            for frame, boxes in sorted(self.hypotheses.items())
            for i, b in sorted(boxes.items())
        ]
        return metrics.write_mot(rows, path)


def trace_from_frames(
    frames: dict[int, run_report.FrameRecord], labels: Sequence[str] = (ANY_LABEL,)
) -> RunTrace:
    """The trace of a recorded graph run (`run_report.collect`); the confirmed tracks of the
    `labels` the run follows (its `track_labels`) are its hypotheses."""
    numbers = run_report.frame_numbers(frames)
    trace = RunTrace(run_report.stream_fps(frames))
    any_label = ANY_LABEL in labels
    for stamp, record in frames.items():
        number = numbers[stamp]
        if record.state is not None:
            trace.windows[number] = msg_to_rect(record.state.window)
            trace.pan_tilt[number] = (record.state.pan, record.state.tilt)
            trace.zooms[number] = record.state.zoom
        if record.tracks is not None:
            followed = [
                t
                for t in record.tracks.tracks
                if t.status == run_report.OBSERVED and (any_label or label_of(t.label) in labels)
            ]
            trace.hypotheses[number] = {t.id: msg_to_rect(t.bbox) for t in followed}
            trace.labels.update((t.id, label_of(t.label)) for t in followed)
            trace.tentative[number] = [
                msg_to_rect(t.bbox)
                for t in record.tracks.tracks
                if t.status == run_report.TENTATIVE and t.consecutive_misses == 0
            ]
        if record.detections is not None:
            trace.detections[number] = [msg_to_rect(b.bbox) for b in record.detections.blobs]
        if record.target is not None and record.target.locked:
            trace.targets[number] = (record.target.track.x, record.target.track.y)
            trace.target_ids[number] = record.target.track.id
    return trace


def trace_from_steps(
    steps: Iterable[Any], fps: float, labels: Sequence[str] = (ANY_LABEL,)
) -> RunTrace:
    """The trace of an in-process run (`pipeline.Step`s, frame n stamped (n - 1) / fps); the
    confirmed tracks of the `labels` the run follows are its hypotheses."""
    trace = RunTrace(fps)
    for number, step in enumerate(steps, start=1):
        trace.windows[number] = step.camera.window
        trace.pan_tilt[number] = (step.camera.pan, step.camera.tilt)
        trace.zooms[number] = step.camera.zoom
        tracks = step.tracks
        observed = np.flatnonzero(
            (tracks.status == TrackStatus.CONFIRMED) & wanted(tracks.labels, labels)
        )
        trace.hypotheses[number] = {
            int(tracks.ids[i]): Rect(*(float(v) for v in tracks.bboxes[i])) for i in observed
        }
        trace.labels.update((int(tracks.ids[i]), str(tracks.labels[i])) for i in observed)
        updated = (tracks.status == TrackStatus.TENTATIVE) & (tracks.misses == 0)
        trace.tentative[number] = [
            Rect(*(float(v) for v in tracks.bboxes[i])) for i in np.flatnonzero(updated)
        ]
        trace.detections[number] = [blob.bbox for blob in step.detection.blobs]
        if step.target is not None and step.target_id is not None:
            trace.targets[number] = (step.target.x, step.target.y)
            trace.target_ids[number] = step.target_id
    return trace


def windows_and_targets(
    frames: dict[int, run_report.FrameRecord],
) -> tuple[dict[int, Rect], dict[int, tuple[float, float]]]:
    """Camera window and locked target position per MOTChallenge frame number."""
    trace = trace_from_frames(frames)
    return trace.windows, trace.targets


@dataclass(frozen=True)
class PanTiltScores:
    locked_share: float  # frames with a locked target
    on_object_share: float  # locked frames whose target position lies on a real object's box
    followed_changes: int  # times the followed object changed
    unexplained_changes: int  # ... while the previous one was still there and lost < REASON_GAP_S
    mean_center_error_px: float  # followed object's box centre to the view centre, on-object frames
    mean_center_error_share: float  # the same, as a share of the view width
    first_lock_s: float | None  # from the first object in the scene to the first on-object lock
    reacquire_s: list[float]  # each time on-object lock was lost: how long until it was back


def followed_objects(truth: Boxes, targets: dict[int, tuple[float, float]]) -> dict[int, int]:
    """Per locked frame, the ground-truth object under the target; frames where it is on no
    object are left out. The object followed before stays the followed one while its box still
    contains the target: a target on two people walking side by side is on both boxes, and the
    nearer centre flipping between them is not the camera changing whom it follows. Otherwise
    it is the box containing the target whose centre is nearest."""
    followed: dict[int, int] = {}
    previous: int | None = None
    for frame in sorted(targets):
        x, y = targets[frame]
        boxes = truth.get(frame, {})
        if previous is not None and previous in boxes and boxes[previous].contains(x, y):
            followed[frame] = previous
            continue
        under = [(math.hypot(b.center[0] - x, b.center[1] - y), i) for i, b in boxes.items()]
        under = [(distance, i) for distance, i in under if boxes[i].contains(x, y)]
        if under:
            followed[frame] = previous = min(under)[1]
    return followed


def pan_tilt_scores(truth: Boxes, trace: RunTrace, counted: Boxes | None = None) -> PanTiltScores:
    """The pan-tilt figures of a run against every ground-truth object (ignored ones included:
    a mostly hidden person is still a real object). A change of the followed object is explained
    when the one followed before is no longer among the `counted` objects (the gt rows with
    conf > 0; default: every object in `truth`): a person whose last sliver is at the scene's
    edge, under the scene's visibility threshold, has left it; or when it is leaving them
    (`_leaving`); or when the target was off it for REASON_GAP_S."""
    counted = truth if counted is None else counted
    frames = sorted(trace.windows)
    followed = followed_objects(truth, trace.targets)
    changes, unexplained, previous, last_seen = 0, 0, None, {}
    errors, shares = [], []
    for frame in frames:
        current = followed.get(frame)
        if current is None:
            continue
        if previous is not None and current != previous:
            changes += 1
            staying = previous in counted.get(frame, {}) and not _leaving(
                previous, frame, counted, trace.fps
            )
            lost_for = (frame - last_seen[previous]) / trace.fps
            unexplained += staying and lost_for < REASON_GAP_S
        previous, last_seen[current] = current, frame
        window = trace.windows[frame]
        errors.append(metrics.centre_distance(truth[frame][current], window))
        shares.append(errors[-1] / window.width)
    first_object = next((f for f in frames if truth.get(f)), None)
    first_lock = next((f for f in frames if f in followed), None)
    return PanTiltScores(
        locked_share=len(trace.targets) / len(frames) if frames else 0.0,
        on_object_share=len(followed) / len(trace.targets) if trace.targets else 0.0,
        followed_changes=changes,
        unexplained_changes=int(unexplained),
        mean_center_error_px=float(np.mean(errors)) if errors else math.nan,
        mean_center_error_share=float(np.mean(shares)) if shares else math.nan,
        first_lock_s=(first_lock - first_object) / trace.fps
        if first_lock is not None and first_object is not None
        else None,
        reacquire_s=_reacquire_times(frames, set(followed), first_lock, trace.fps),
    )


def _leaving(obj: int, frame: int, counted: Boxes, fps: float) -> bool:
    """Whether `obj`, counted at `frame`, leaves the counted objects within EXIT_GRACE_S and
    stays out of them for REASON_GAP_S (or to the end of the ground truth)."""
    last = max(counted, default=frame)
    grace, gap = round(EXIT_GRACE_S * fps), round(REASON_GAP_S * fps)
    for start in range(frame + 1, min(frame + grace, last) + 1):
        out = range(start, min(start + gap, last) + 1)
        if all(obj not in counted.get(f, {}) for f in out):
            return True
    return False


def _reacquire_times(
    frames: list[int], on_object: set[int], first_lock: int | None, fps: float
) -> list[float]:
    times, lost_at = [], None
    for frame in frames:
        if first_lock is None or frame < first_lock:
            continue
        if frame in on_object:
            if lost_at is not None:
                times.append((frame - lost_at) / fps)
            lost_at = None
        elif lost_at is None:
            lost_at = frame
    return times


def score_trace(
    trace: RunTrace, gt: Path, label_of: LabelImages | None = None, centres: bool = False
) -> dict[str, Any]:
    """Every score of a run against a MOTChallenge gt.txt (conf-0 rows: ignored objects) and,
    when given, the scene's label images (`label_of(frame)`: pixel value = object id); with
    `centres` also the scores on box centres (`centre_scores.centre_scores`) as "centres"."""
    truth = metrics.load_mot(gt)
    ignored = metrics.load_mot(gt, ignored=True)
    hypotheses = metrics.without_ignored(trace.hypotheses, truth, ignored)
    frames = sorted(trace.windows)
    view_truth, view_ignored = _view_truth(truth, ignored, trace.windows, label_of)
    view_hypotheses = metrics.without_ignored(hypotheses, view_truth, view_ignored)
    result = {
        "frames": len(frames),
        "in_view": _tracking_scores(view_truth, view_hypotheses, frames),
        "whole_scene": _tracking_scores(truth, hypotheses, frames),
        "pan_tilt": asdict(pan_tilt_scores(metrics.every_object(gt), trace, truth)),
        "errors_in_view": error_classes.error_classes(
            view_truth, view_hypotheses, trace.detections, trace.tentative, frames
        ),
    }
    if centres:
        result["centres"] = centre_scores.centre_scores(truth, ignored, trace.hypotheses, frames)
    return result


def _view_truth(
    truth: Boxes, ignored: Boxes, windows: dict[int, Rect], label_of: LabelImages | None
) -> tuple[Boxes, Boxes]:
    """The counted and the ignored objects as the camera images show them."""
    if label_of is None:
        return metrics.in_view(truth, windows), metrics.in_view(ignored, windows)
    counted, partial_views = metrics.visible_in_view(label_of, truth, windows)
    # An ignored object (barely visible in the scene) stays ignored however much of it is in view.
    _, hidden = metrics.visible_in_view(label_of, ignored, windows, min_share=math.inf)
    for frame, boxes in hidden.items():
        partial_views.setdefault(frame, {}).update(boxes)
    return counted, partial_views


def _tracking_scores(truth: Boxes, hypotheses: Boxes, frames: list[int]) -> dict[str, Any]:
    return {
        **asdict(metrics.clear_mot(truth, hypotheses, frames)),
        **asdict(metrics.hota(truth, hypotheses, frames)),
    }


def write_json(data: Any, path: Path) -> None:
    """JSON with NaN written as null (JSON has no NaN)."""
    path.write_text(json.dumps(_nan_to_none(data), indent=2) + "\n")


def _nan_to_none(value: Any) -> Any:
    if isinstance(value, float) and math.isnan(value):
        return None
    if isinstance(value, dict):
        return {k: _nan_to_none(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_nan_to_none(v) for v in value]
    return value


def format_scores(result: dict) -> str:
    rows = [("frames", str(result["frames"]))]
    for name in ("in_view", "whole_scene"):
        s = result[name]
        rows.append(
            (
                name.replace("_", " "),
                f"MOTA {s['mota']:.3f}  IDF1 {s['idf1']:.3f}  HOTA {s['hota']:.3f}  "
                f"MOTP {s['motp']:.3f}  id switches {s['id_switches']}  "
                f"recall {s['recall']:.3f}  precision {s['precision']:.3f}",
            )
        )
    errors = result.get("errors_in_view")
    if errors:

        def counted(names: tuple[str, ...]) -> str:
            return ", ".join(f"{n.replace('_', ' ')} {errors[n]}" for n in names if errors[n])

        rows.append(
            (
                "errors in view",
                f"misses: {counted(error_classes.MISSES)}; "
                f"false: {counted(error_classes.FALSE_POSITIVES)}",
            )
        )
    if "centres" in result:
        c = result["centres"]
        ospa = "  ".join(
            f"OSPA c={k.removeprefix('ospa_').removesuffix('px')} px {v:.2f}"
            for k, v in c.items()
            if k.startswith("ospa_")
        )
        rows.append(
            (
                "box centres",
                f"MOTA {c['mota']:.3f}  IDF1 {c['idf1']:.3f}  id switches {c['id_switches']}  "
                f"recall {c['recall']:.3f}  false alarms {c['false_alarm_rate']:.3f}  "
                f"missed occlusions {c['missed_occlusions']}/{c['occlusions']}  {ospa} "
                f"(match {c['match_distance_px']:g} px)",
            )
        )
    p = result["pan_tilt"]
    first = "never" if p["first_lock_s"] is None else f"{p['first_lock_s']:.1f} s"
    reacquire = p["reacquire_s"]
    rows += [
        (
            "target",
            f"locked {100 * p['locked_share']:.1f} % of frames, on a real object in "
            f"{100 * p['on_object_share']:.1f} % of those; first lock after {first}",
        ),
        (
            "followed object",
            f"changed {p['followed_changes']} times, {p['unexplained_changes']} without a reason; "
            f"re-acquired {len(reacquire)} times"
            + (f" (mean {np.mean(reacquire):.1f} s)" if reacquire else ""),
        ),
        (
            "centring error",
            "n/a"
            if p["mean_center_error_px"] is None or math.isnan(p["mean_center_error_px"])
            else f"{p['mean_center_error_px']:.1f} px "
            f"({100 * p['mean_center_error_share']:.1f} % of view width)",
        ),
    ]
    width = max(len(n) for n, _ in rows)
    return "\n".join(f"  {n:<{width}}  {v}" for n, v in rows)
