"""What a recorded run produced, read back from its bag (no rclpy): the annotated video, the tracks
in MOTChallenge format, and the summary (frames, throughput, per-hop latency, lock share, centring).

Latencies come from the recorder's receive times (its callback times) of the messages that share
one image stamp, so they measure the graph as a user sees it (serialization, DDS and each node's
processing), to within the recorder's own lag: it is the busiest process, and a hop shorter than
a millisecond can come out negative on a frame (each hop's `min` shows it). scripts/two_hosts.py
times such a hop on the middleware's timestamps instead.
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from tracker_msgs_py.codec import NS_PER_S, decode_image, msg_to_rect, stamp_to_ns
from tracker_msgs_py.labels import MOTION, label_of
from tracker_ptz_sim.evaluation.metrics import mot_row
from tracker_ptz_sim.evaluation.metrics import write_mot as write_mot_rows
from tracker_ptz_sim.evaluation.recording import read_bag

SCENE, CAMERA = "/scene/image_raw", "/camera/image_raw"
STATE, DETECTIONS, TRACKS, TARGET, COMMAND = (
    "/ptz/state",
    "/detections",
    "/tracks",
    "/target",
    "/ptz/command",
)
# Hops of one frame through the graph, as (name, from topic, to topic).
HOPS = [
    ("video_source -> ptz_camera", SCENE, CAMERA),
    ("ptz_camera -> ssim_detector", CAMERA, DETECTIONS),
    ("ssim_detector -> tracker", DETECTIONS, TARGET),
    ("tracker -> ptz_controller", TARGET, COMMAND),
    ("camera image -> command", CAMERA, COMMAND),
]
CONFIRMED_STATUSES = (1, 2)  # Track.STATUS_CONFIRMED, STATUS_COASTING
TENTATIVE = 0  # Track.STATUS_TENTATIVE: not yet confirmed
OBSERVED = 1  # Track.STATUS_CONFIRMED: confirmed and updated by a detection this frame
COASTING = 2  # Track.STATUS_COASTING: a prediction, not an observation


@dataclass
class FrameRecord:
    """Everything the graph said about one camera image."""

    stamp: int
    received: dict[str, int] = field(default_factory=dict)  # topic -> receive time ns
    state: Any = None
    detections: Any = None
    tracks: Any = None
    target: Any = None
    command: Any = None


@dataclass
class Summary:
    frames: int
    duration_s: float
    throughput_fps: float
    latency_ms: dict[str, dict[str, float]]
    locked_share: float
    mean_center_distance_px: float | None
    mean_center_distance_share: float | None  # of the view width
    tracks_seen: int
    messages: dict[str, int]


def collect(bag: Path) -> dict[int, FrameRecord]:
    """Per image stamp: the non-image messages, and every topic's receive time."""
    frames: dict[int, FrameRecord] = {}
    slots = {
        STATE: "state",
        DETECTIONS: "detections",
        TRACKS: "tracks",
        TARGET: "target",
        COMMAND: "command",
    }
    for topic, received, msg in read_bag(bag, {SCENE, CAMERA, *slots}):
        stamp = stamp_to_ns(msg.header.stamp)
        record = frames.setdefault(stamp, FrameRecord(stamp))
        record.received.setdefault(topic, received)
        if topic in slots:
            setattr(record, slots[topic], msg)
    return dict(sorted(frames.items()))


def latency_stats(values_ms: Sequence[float]) -> dict[str, float]:
    """min, p50, p95 and max of a hop's per-frame latencies (ms; at least one)."""
    return {
        "min": float(np.min(values_ms)),
        "p50": float(np.percentile(values_ms, 50)),
        "p95": float(np.percentile(values_ms, 95)),
        "max": float(np.max(values_ms)),
    }


def summarize(frames: dict[int, FrameRecord], message_counts: dict[str, int]) -> Summary:
    scene_times = sorted(r.received[SCENE] for r in frames.values() if SCENE in r.received)
    count = len(scene_times)
    duration = (scene_times[-1] - scene_times[0]) / NS_PER_S if count > 1 else 0.0
    latency = {}
    for name, source, sink in HOPS:
        values = [
            (r.received[sink] - r.received[source]) / 1e6
            for r in frames.values()
            if source in r.received and sink in r.received
        ]
        if values:
            latency[name] = latency_stats(values)
    locked = [r for r in frames.values() if r.target is not None and r.target.locked]
    with_state = [r for r in frames.values() if r.target is not None]
    distances, shares = [], []
    for record in locked:
        if record.state is None:
            continue
        window = msg_to_rect(record.state.window)
        cx, cy = window.center
        distance = float(np.hypot(record.target.track.x - cx, record.target.track.y - cy))
        distances.append(distance)
        shares.append(distance / window.width)
    track_ids = {
        t.id
        for r in frames.values()
        if r.tracks is not None
        for t in r.tracks.tracks
        if t.status in CONFIRMED_STATUSES
    }
    return Summary(
        frames=count,
        duration_s=duration,
        throughput_fps=(count - 1) / duration if duration > 0 else 0.0,
        latency_ms=latency,
        locked_share=len(locked) / len(with_state) if with_state else 0.0,
        mean_center_distance_px=float(np.mean(distances)) if distances else None,
        mean_center_distance_share=float(np.mean(shares)) if shares else None,
        tracks_seen=len(track_ids),
        messages=message_counts,
    )


def stream_fps(frames: dict[int, FrameRecord], default: float = 10.0) -> float:
    """The recording's frame rate, from the median spacing of the image stamps."""
    stamps = list(frames)
    if len(stamps) < 2:
        return default
    spacing = float(np.median(np.diff(stamps))) / NS_PER_S
    return 1.0 / spacing if spacing > 0 else default


def frame_numbers(frames: dict[int, FrameRecord]) -> dict[int, int]:
    """MOTChallenge frame number (from 1) of each stamp.

    Replays of video files stamp frame i at i / fps, so the number is recovered from the stamp and
    frames the graph skipped keep their place; other stamps (bags) are numbered in order.
    """
    stamps = list(frames)
    fps = stream_fps(frames)
    indices = [s * fps / NS_PER_S for s in stamps]
    if all(abs(i - round(i)) < 0.01 for i in indices):
        return {s: int(round(i)) + 1 for s, i in zip(stamps, indices, strict=True)}
    return {s: n for n, s in enumerate(stamps, start=1)}


def write_mot(frames: dict[int, FrameRecord], path: Path) -> int:
    """Confirmed tracks observed in each frame, in MOTChallenge format (coasting predictions are
    not observed boxes, so they are left out, as MOTChallenge trackers do)."""
    numbers = frame_numbers(frames)
    rows = [
        mot_row(numbers[stamp], track.id, msg_to_rect(track.bbox), track.existence, track.label)
        for stamp, record in frames.items()
        if record.tracks is not None
        for track in record.tracks.tracks
        if track.status == OBSERVED
    ]
    return write_mot_rows(rows, path)


PAIRING_WINDOW = 3  # scene frames kept waiting for their camera image while rendering


def render_video(
    bag: Path,
    frames: dict[int, FrameRecord],
    path: Path,
    fps: float,
    progress: Callable[[int], None] | None = None,
) -> int:
    """The annotated run: the scene with window, blobs, tracks and target; the camera view beside.

    The camera image of a frame is recorded after or before its scene image (they come from
    different nodes), so a scene frame waits until its camera image is read, or until
    PAIRING_WINDOW later scene frames are (then it is drawn without one). A scene image repeating
    the one before (a lockstep re-send) is drawn once."""
    writer: cv2.VideoWriter | None = None
    waiting: dict[int, Any] = {}  # scene messages by stamp, in the order they were recorded
    cameras: dict[int, Any] = {}
    last_scene: int | None = None
    drawn = 0

    def draw(stamp: int) -> None:
        nonlocal writer, drawn
        canvas = _annotated_frame(waiting.pop(stamp), cameras.pop(stamp, None), frames.get(stamp))
        if writer is None:
            writer = _open_writer(path, fps, canvas)
        writer.write(canvas)
        drawn += 1
        if progress:
            progress(drawn)

    try:
        for topic, _, msg in read_bag(bag, {SCENE, CAMERA}):
            stamp = stamp_to_ns(msg.header.stamp)
            if topic == CAMERA:
                cameras[stamp] = msg
            elif stamp != last_scene:
                waiting[stamp] = msg
                last_scene = stamp
            while (ready := _next_to_draw(waiting, cameras)) is not None:
                draw(ready)
            _drop_unpaired(cameras)
        for stamp in list(waiting):
            draw(stamp)
    finally:
        if writer is not None:
            writer.release()
    return drawn


def _annotated_frame(scene: Any, camera: Any | None, record: FrameRecord | None) -> np.ndarray:
    """One frame of the annotated video: the annotated scene image, the camera's view (its image
    message, None when it never came) beside it."""
    canvas = annotate_scene(decode_image(scene), record)
    view = None if camera is None else decode_image(camera)
    return side_by_side(canvas, annotate_view(view, canvas.shape[0]))


def _open_writer(path: Path, fps: float, canvas: np.ndarray) -> cv2.VideoWriter:
    """An MP4 writer of frames the size of `canvas`; OSError when OpenCV cannot write `path`."""
    size = (canvas.shape[1], canvas.shape[0])
    fourcc = cv2.VideoWriter_fourcc(*"mp4v")  # type: ignore[attr-defined]  # not in stubs
    writer = cv2.VideoWriter(str(path), fourcc, fps, size)
    if not writer.isOpened():
        raise OSError(f"OpenCV cannot write {path}")
    return writer


def _next_to_draw(waiting: dict[int, Any], cameras: dict[int, Any]) -> int | None:
    """The oldest waiting scene frame's stamp once its camera image is read or PAIRING_WINDOW
    later scene frames are; None while it (or nothing) waits."""
    if not waiting:
        return None
    oldest = next(iter(waiting))
    ready = oldest in cameras or len(waiting) > PAIRING_WINDOW
    return oldest if ready else None


def _drop_unpaired(cameras: dict[int, Any]) -> None:
    """Forget the oldest camera images beyond 4 x PAIRING_WINDOW: their scene never came."""
    while len(cameras) > 4 * PAIRING_WINDOW:
        del cameras[next(iter(cameras))]


UNCLASSIFIED_COLOUR = (200, 200, 200)  # BGR: blobs and tracks labelled motion (not followed)


def annotate_scene(image: np.ndarray, record: FrameRecord | None) -> np.ndarray:
    """Outside the camera window greyed (as the seed shows it); window, detections (person boxes
    red, unclassified blobs grey), tracks (motion tracks grey, labelled) and target drawn."""
    if record is None or record.state is None:
        return image
    window = record.state.window
    x0, y0 = int(round(window.x)), int(round(window.y))
    x1, y1 = int(round(window.x + window.width)), int(round(window.y + window.height))
    grey = cv2.cvtColor(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), cv2.COLOR_GRAY2BGR)
    canvas = (grey * 0.6).astype(np.uint8)
    canvas[y0:y1, x0:x1] = image[y0:y1, x0:x1]
    cv2.rectangle(canvas, (x0, y0), (x1 - 1, y1 - 1), (0, 200, 0), 2)
    if record.detections is not None:
        for blob in record.detections.blobs:
            b = blob.bbox
            colour = UNCLASSIFIED_COLOUR if label_of(blob.label) == MOTION else (0, 0, 255)
            cv2.rectangle(canvas, _pt(b.x, b.y), _pt(b.x + b.width, b.y + b.height), colour, 1)
    target_id = (
        record.target.track.id if record.target is not None and record.target.locked else None
    )
    if record.tracks is not None:
        for track in record.tracks.tracks:
            if track.status not in CONFIRMED_STATUSES:
                continue
            unclassified = label_of(track.label) == MOTION and target_id != track.id
            color = UNCLASSIFIED_COLOUR if unclassified else _track_color(track.id)
            b = track.bbox
            thick = 3 if track.id == target_id else 1
            corners = _pt(b.x, b.y), _pt(b.x + b.width, b.y + b.height)
            if track.status == COASTING:
                dashed_rectangle(canvas, *corners, color, thick)
            else:
                cv2.rectangle(canvas, *corners, color, thick)
            cv2.putText(
                canvas,
                f"#{track.id}" + (f" {MOTION}" if unclassified else ""),
                _pt(b.x, b.y - 4),
                cv2.FONT_HERSHEY_SIMPLEX,
                0.5,
                color,
                1,
            )
    if target_id is not None:
        target = record.target
        cv2.circle(canvas, _pt(target.track.x, target.track.y), 6, (0, 255, 255), 2)
        cv2.drawMarker(
            canvas,
            _pt(target.predicted_x, target.predicted_y),
            (255, 255, 0),
            cv2.MARKER_CROSS,
            12,
            2,
        )
    return canvas


def annotate_view(view: np.ndarray | None, height: int) -> np.ndarray:
    if view is None:
        return np.zeros((height, height, 3), np.uint8)
    scale = height / view.shape[0]
    return cv2.resize(
        view, (int(round(view.shape[1] * scale)), height), interpolation=cv2.INTER_NEAREST
    )


def side_by_side(left: np.ndarray, right: np.ndarray) -> np.ndarray:
    return np.hstack([left, np.full((left.shape[0], 4, 3), 255, np.uint8), right])


def dashed_rectangle(
    image: np.ndarray,
    top_left: tuple[int, int],
    bottom_right: tuple[int, int],
    color: tuple[int, int, int],
    thickness: int = 1,
    dash: int = 6,
) -> None:
    """A rectangle of `dash`-px strokes (a coasting track: predicted, not seen)."""
    (x0, y0), (x1, y1) = top_left, bottom_right
    for a, b in (
        ((x0, y0), (x1, y0)),
        ((x1, y0), (x1, y1)),
        ((x1, y1), (x0, y1)),
        ((x0, y1), (x0, y0)),
    ):
        length = max(abs(b[0] - a[0]), abs(b[1] - a[1]))
        for start in range(0, length, 2 * dash):
            end = min(start + dash, length)
            p = (
                a[0] + (b[0] - a[0]) * start // max(length, 1),
                a[1] + (b[1] - a[1]) * start // max(length, 1),
            )
            q = (
                a[0] + (b[0] - a[0]) * end // max(length, 1),
                a[1] + (b[1] - a[1]) * end // max(length, 1),
            )
            cv2.line(image, p, q, color, thickness)


def _pt(x: float, y: float) -> tuple[int, int]:
    return (int(round(x)), int(round(y)))


def _track_color(track_id: int) -> tuple[int, int, int]:
    hue = (track_id * 47) % 180
    color = cv2.cvtColor(np.array([[[hue, 220, 255]]], np.uint8), cv2.COLOR_HSV2BGR)[0, 0]
    return (int(color[0]), int(color[1]), int(color[2]))


def format_summary(summary: Summary) -> str:
    """The summary as the table the demo prints."""
    rows = [
        ("frames", f"{summary.frames}"),
        ("wall time", f"{summary.duration_s:.1f} s"),
        ("throughput", f"{summary.throughput_fps:.1f} frames/s"),
        ("target locked", f"{100 * summary.locked_share:.1f} % of frames"),
    ]
    share = summary.mean_center_distance_share
    if summary.mean_center_distance_px is not None and share is not None:
        rows.append(
            (
                "target from view centre",
                f"{summary.mean_center_distance_px:.1f} px ({100 * share:.1f} % of view width)",
            )
        )
    rows.append(("confirmed tracks", f"{summary.tracks_seen}"))
    for hop, stats in summary.latency_ms.items():
        rows.append((f"latency {hop}", f"p50 {stats['p50']:.1f} ms, p95 {stats['p95']:.1f} ms"))
    width = max(len(name) for name, _ in rows)
    return "\n".join(f"  {name:<{width}}  {value}" for name, value in rows)


def write_summary(summary: Summary, path: Path, run: dict[str, Any] | None = None) -> None:
    """summary.json: the summary's fields, and the runner's account of the run under "run"."""
    data = asdict(summary)
    if run is not None:
        data["run"] = run
    path.write_text(json.dumps(data, indent=2) + "\n")


def message_counts(frames: dict[int, FrameRecord]) -> dict[str, int]:
    counts: dict[str, int] = defaultdict(int)
    for record in frames.values():
        for topic in record.received:
            counts[topic] += 1
    return dict(counts)
