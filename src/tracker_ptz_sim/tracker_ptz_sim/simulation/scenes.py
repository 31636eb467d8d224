"""Deterministic synthetic scenes with ground truth, for tests and benchmarks (no rclpy).

A scene is a short clip of a textured background with moving textured objects, rendered from a
seed so the same :class:`SceneConfig` always gives the same pixels. Besides the frames it carries
the ground truth a detector or tracker is scored against:

- ``labels``: per frame and pixel, the id of the object *visible* there (0 = background). Static
  occluders are part of the background, so ``labels > 0`` is the foreground mask a motion detector
  should find (objects that have stopped included: the mask is ground truth, not what a frame
  difference can see).
- ``boxes``: per frame, the full extent of every object present (its box may reach beyond the
  frame while it enters or leaves) with its visibility, the fraction of its pixels not hidden by
  occluders, nearer objects or the frame border (MOTChallenge's meaning).

Coordinates: image pixels of the rendered frame, x right, y down, the origin at the top-left
corner of the top-left pixel (as ``tracker_msgs/Rect``). With camera jitter the whole world is
shifted by ``jitter[n] = (dx, dy)`` in frame n, and frames, labels and boxes are all given in the
shifted image coordinates (world position = image position - jitter).

Files: :mod:`tracker_ptz_sim.simulation.scene_files` writes and reads the scenes of every
generator (this module's, the street scenes of :mod:`tracker_ptz_sim.simulation.street` and the
small-object scenes of :mod:`tracker_ptz_sim.simulation.small_objects`, whose ground truth boxes
are the visible boxes, with ``conf`` 0 for the barely visible ones, and whose labels are uint16).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import cv2
import numpy as np

from tracker_msgs_py.codec import frame_stamp_ns
from tracker_msgs_py.params import check_config


class GeneratorConfig(Protocol):
    """What a scene keeps of the config it was generated from (this module's `SceneConfig`, the
    street's and the small-object scenes'): the generator's name, and its fields (a dataclass)."""

    generator: ClassVar[str]
    __dataclass_fields__: ClassVar[dict[str, Any]]


@dataclass(frozen=True)
class SceneConfig:
    """Everything that defines a synthetic scene; the same config always renders the same scene."""

    generator: ClassVar[str] = "objects"  # scene.json's "generator" for this kind of config

    width: int = 320  # px
    height: int = 240  # px
    num_frames: int = 60
    fps: float = 10.0
    num_objects: int = 2
    object_size_range: tuple[int, int] = (16, 40)  # px, range of each object's width and height
    speed_range: tuple[float, float] = (20.0, 60.0)  # px/s
    turns: int = 1  # direction changes per object, at random frames
    stops: int = 0  # stops per object, each lasting stop_duration
    stop_duration: float = 1.0  # s
    entries_exits: bool = (
        False  # objects enter through a border and leave (else they bounce inside)
    )
    num_occluders: int = 0  # static textured rectangles in front of the objects
    occluder_size_range: tuple[int, int] = (20, 60)  # px
    noise_sigma: float = 2.0  # grey levels, Gaussian sensor noise, new every frame
    illumination_drift: float = 0.0  # relative amplitude of a slow sinusoidal gain, 0.1 = +-10 %
    illumination_period: float = 20.0  # s
    camera_jitter: int = 0  # px, per-frame camera offset drawn uniformly from [-j, j] per axis
    seed: int = 0

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        """Why this scene cannot be rendered (empty: it can)."""
        c = self
        problems = clip_problems(c, min_side=16)
        problems += negative_counts(
            c, ("num_objects", "turns", "stops", "num_occluders", "camera_jitter")
        )
        for name in ("object_size_range", "occluder_size_range"):
            lo, hi = getattr(c, name)
            if not 2 <= lo <= hi <= min(c.width, c.height):
                problems.append(f"{name} must satisfy 2 <= min <= max <= {min(c.width, c.height)}")
        lo, hi = c.speed_range
        if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo <= hi):
            problems.append(f"speed_range must satisfy 0 <= min <= max, got {c.speed_range}")
        for name in ("stop_duration", "noise_sigma", "illumination_drift", "illumination_period"):
            value = getattr(c, name)
            if not (math.isfinite(value) and value >= 0):
                problems.append(f"{name} must be a finite number >= 0, got {value}")
        if c.illumination_drift >= 1.0:
            problems.append(f"illumination_drift must be < 1, got {c.illumination_drift}")
        return problems


def clip_problems(config: Any, min_side: int) -> list[str]:
    """Why a scene config's clip (width, height, num_frames, fps) cannot be rendered."""
    c, problems = config, []
    if c.width < min_side or c.height < min_side:
        problems.append(
            f"scene size must be at least {min_side}x{min_side}, got {c.width}x{c.height}"
        )
    if c.num_frames < 1:
        problems.append(f"num_frames must be >= 1, got {c.num_frames}")
    if not (math.isfinite(c.fps) and c.fps > 0):
        problems.append(f"fps must be positive, got {c.fps}")
    return problems


def negative_counts(config: Any, names: tuple[str, ...]) -> list[str]:
    """A problem for each of the config's count fields `names` that is negative."""
    return [f"{n} must be >= 0, got {getattr(config, n)}" for n in names if getattr(config, n) < 0]


@dataclass(frozen=True)
class GroundTruthBox:
    """One object's box in one frame (image px) and the visible fraction of its pixels.

    ``conf`` is the MOTChallenge gt.txt flag: 1 = score it, 0 = ignore it (street scenes set 0
    for boxes that are barely visible)."""

    frame: int  # 0-based frame index
    object_id: int  # >= 1
    x: float
    y: float
    width: float
    height: float
    visibility: float  # [0, 1]
    conf: int = 1


@dataclass
class Scene:
    """A rendered scene: frames and their ground truth (see the module docstring)."""

    frames: np.ndarray  # (N, H, W, 3) uint8 BGR
    fps: float
    labels: np.ndarray  # (N, H, W) int32 (street, small objects: uint16), visible id, 0 = none
    boxes: list[list[GroundTruthBox]]  # per frame
    jitter: np.ndarray  # (N, 2) int, camera offset (dx, dy) applied to frame n
    config: GeneratorConfig | None = None

    @property
    def num_frames(self) -> int:
        return int(self.frames.shape[0])

    def stamps_ns(self) -> list[int]:
        """Recording stamps of the frames, index / fps, as a replay would publish them."""
        return [frame_stamp_ns(i, self.fps) for i in range(self.num_frames)]


def _texture(
    rng: np.random.Generator, height: int, width: int, scales: tuple[float, ...]
) -> np.ndarray:
    """Multi-scale smoothed noise, float32 (H, W, 3), zero mean and roughly unit spread."""
    out = np.zeros((height, width, 3), np.float32)
    for sigma in scales:
        noise = rng.standard_normal((height, width, 3)).astype(np.float32)
        smooth = cv2.GaussianBlur(noise, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
        out += (smooth / max(float(smooth.std()), 1e-6)).astype(np.float32)
    return out / math.sqrt(len(scales))


def _background(rng: np.random.Generator, height: int, width: int) -> np.ndarray:
    base = rng.uniform(90, 160, size=3).astype(np.float32)
    texture = _texture(rng, height, width, (1.0, 3.0, 12.0))
    ramp = np.linspace(-20, 20, width, dtype=np.float32)[None, :, None]
    return base + 28.0 * texture + ramp


@dataclass
class _Object:
    object_id: int
    depth: float  # larger = nearer the camera, drawn later
    width: int
    height: int
    appearance: np.ndarray  # (h, w, 3) float32
    shape: np.ndarray  # (h, w) bool, an ellipse filling the box
    positions: np.ndarray  # (N, 2) float, top-left corner in world px
    present: np.ndarray  # (N,) bool


@dataclass
class _Occluder:
    x: int
    y: int
    appearance: np.ndarray  # (h, w, 3) float32


@dataclass
class _Schedule:
    turn_frames: set[int] = field(default_factory=set)
    stopped: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))


def _unit(angle: float) -> np.ndarray:
    return np.array([math.cos(angle), math.sin(angle)])


def _schedule(rng: np.random.Generator, config: SceneConfig) -> _Schedule:
    n = config.num_frames
    turns: np.ndarray | list[int] = (
        rng.choice(np.arange(1, n), size=min(config.turns, n - 1), replace=False) if n > 1 else []
    )
    stopped = np.zeros(n, bool)
    stop_len = max(1, round(config.stop_duration * config.fps))
    for start in rng.integers(0, n, size=config.stops):
        stopped[start : start + stop_len] = True
    return _Schedule({int(t) for t in turns}, stopped)


def _entry(
    rng: np.random.Generator, config: SceneConfig, w: int, h: int
) -> tuple[np.ndarray, float]:
    """Start just outside a random border, heading to a random point of the central area."""
    W, H = config.width, config.height
    side = int(rng.integers(4))
    along = rng.uniform(0.2, 0.8)
    start = {
        0: (-w, along * H - h / 2),
        1: (W, along * H - h / 2),
        2: (along * W - w / 2, -h),
        3: (along * W - w / 2, H),
    }[side]
    goal = rng.uniform([0.3 * W, 0.3 * H], [0.7 * W, 0.7 * H]) - (w / 2, h / 2)
    heading = math.atan2(goal[1] - start[1], goal[0] - start[0])
    return np.array(start, float), heading


def _trajectory(
    rng: np.random.Generator, config: SceneConfig, w: int, h: int
) -> tuple[np.ndarray, np.ndarray]:
    n, dt = config.num_frames, 1.0 / config.fps
    speed = rng.uniform(*config.speed_range)
    schedule = _schedule(rng, config)
    present = np.zeros(n, bool)
    positions = np.zeros((n, 2))
    if config.entries_exits:
        first = int(rng.integers(0, max(1, n // 2)))
        pos, heading = _entry(rng, config, w, h)
    else:
        first = 0
        pos = rng.uniform([0, 0], [config.width - w, config.height - h])
        heading = rng.uniform(0, 2 * math.pi)
    velocity = speed * _unit(heading)
    turn_angles = rng.uniform(math.pi / 4, 3 * math.pi / 4, size=n) * rng.choice([-1, 1], size=n)
    entered = False
    for k in range(first, n):
        if k in schedule.turn_frames:
            angle = math.atan2(velocity[1], velocity[0]) + turn_angles[k]
            velocity = speed * _unit(angle)
        if k > first and not schedule.stopped[k]:
            pos = pos + velocity * dt
            if not config.entries_exits:
                pos, velocity = _bounce(pos, velocity, config.width - w, config.height - h)
        visible = (
            pos[0] < config.width and pos[1] < config.height and pos[0] + w > 0 and pos[1] + h > 0
        )
        if config.entries_exits and entered and not visible:
            break  # it left through a border: gone for good
        entered = entered or visible
        present[k] = visible
        positions[k] = pos
    return positions, present


def _bounce(
    pos: np.ndarray, velocity: np.ndarray, max_x: float, max_y: float
) -> tuple[np.ndarray, np.ndarray]:
    pos, velocity = pos.copy(), velocity.copy()
    for axis, hi in ((0, max_x), (1, max_y)):
        if pos[axis] < 0:
            pos[axis], velocity[axis] = -pos[axis], abs(velocity[axis])
        elif pos[axis] > hi:
            pos[axis], velocity[axis] = 2 * hi - pos[axis], -abs(velocity[axis])
        pos[axis] = min(max(pos[axis], 0.0), hi)
    return pos, velocity


def _make_objects(rng: np.random.Generator, config: SceneConfig) -> list[_Object]:
    objects = []
    depths = rng.permutation(config.num_objects)
    for i in range(config.num_objects):
        lo, hi = config.object_size_range
        w, h = (int(v) for v in rng.integers(lo, hi + 1, size=2))
        colour = rng.uniform(30, 225, size=3).astype(np.float32)
        appearance = colour + 35.0 * _texture(rng, h, w, (0.8, 2.5))
        yy, xx = np.mgrid[0:h, 0:w]
        shape = ((xx + 0.5 - w / 2) / (w / 2)) ** 2 + ((yy + 0.5 - h / 2) / (h / 2)) ** 2 <= 1.0
        positions, present = _trajectory(rng, config, w, h)
        objects.append(
            _Object(i + 1, float(depths[i]), w, h, appearance, shape, positions, present)
        )
    return objects


def _make_occluders(rng: np.random.Generator, config: SceneConfig) -> list[_Occluder]:
    occluders = []
    for _ in range(config.num_occluders):
        lo, hi = config.occluder_size_range
        w, h = (int(v) for v in rng.integers(lo, hi + 1, size=2))
        x = int(rng.integers(0, config.width - w + 1))
        y = int(rng.integers(0, config.height - h + 1))
        colour = rng.uniform(40, 215, size=3).astype(np.float32)
        occluders.append(_Occluder(x, y, colour + 25.0 * _texture(rng, h, w, (1.5, 6.0))))
    return occluders


def _paste(
    canvas: np.ndarray, patch: np.ndarray, x: int, y: int, mask: np.ndarray | None = None
) -> np.ndarray | None:
    """Paste ``patch`` at (x, y) clipped to ``canvas``; returns the canvas-sized mask it covered."""
    H, W = canvas.shape[:2]
    h, w = patch.shape[:2]
    x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + w, W), min(y + h, H)
    if x1 <= x0 or y1 <= y0:
        return None
    sub = patch[y0 - y : y1 - y, x0 - x : x1 - x]
    sub_mask = (
        np.ones(sub.shape[:2], bool) if mask is None else mask[y0 - y : y1 - y, x0 - x : x1 - x]
    )
    canvas[y0:y1, x0:x1][sub_mask] = sub[sub_mask]
    covered = np.zeros((H, W), bool)
    covered[y0:y1, x0:x1] = sub_mask
    return covered


def generate_scene(config: SceneConfig) -> Scene:
    """Render the scene ``config`` describes; deterministic for a given config (seed included)."""
    rng = np.random.default_rng(config.seed)
    margin = config.camera_jitter
    W, H, N = config.width, config.height, config.num_frames
    background = _background(rng, H + 2 * margin, W + 2 * margin)
    objects = sorted(_make_objects(rng, config), key=lambda o: o.depth)
    occluders = _make_occluders(rng, config)
    jitter = rng.integers(-margin, margin + 1, size=(N, 2)) if margin else np.zeros((N, 2), int)
    frames = np.empty((N, H, W, 3), np.uint8)
    labels = np.zeros((N, H, W), np.int32)
    boxes: list[list[GroundTruthBox]] = []
    for n in range(N):
        dx, dy = int(jitter[n, 0]), int(jitter[n, 1])
        canvas = background[margin - dy : margin - dy + H, margin - dx : margin - dx + W].copy()
        label = labels[n]
        drawn: list[tuple[_Object, int, int]] = []
        for obj in objects:
            if not obj.present[n]:
                continue
            x, y = (int(round(v)) for v in obj.positions[n])
            covered = _paste(canvas, obj.appearance, x + dx, y + dy, obj.shape)
            if covered is not None:
                label[covered] = obj.object_id
            drawn.append((obj, x + dx, y + dy))
        for occ in occluders:
            covered = _paste(canvas, occ.appearance, occ.x + dx, occ.y + dy)
            if covered is not None:
                label[covered] = 0
        boxes.append(_frame_boxes(n, drawn, label))
        gain = _illumination_gain(config, n)
        noise = rng.standard_normal(canvas.shape).astype(np.float32) * config.noise_sigma
        frames[n] = np.clip(np.rint(canvas * gain + noise), 0, 255).astype(np.uint8)
    return Scene(frames, float(config.fps), labels, boxes, jitter.astype(np.int64), config)


def _illumination_gain(config: SceneConfig, n: int) -> float:
    if config.illumination_drift == 0 or config.illumination_period == 0:
        return 1.0
    phase = 2 * math.pi * (n / config.fps) / config.illumination_period
    return 1.0 + config.illumination_drift * math.sin(phase)


def _frame_boxes(
    n: int, drawn: list[tuple[_Object, int, int]], label: np.ndarray
) -> list[GroundTruthBox]:
    visible_counts = np.bincount(
        label.ravel(), minlength=max((o.object_id for o, _, _ in drawn), default=0) + 1
    )
    boxes = []
    for obj, x, y in sorted(drawn, key=lambda d: d[0].object_id):
        visibility = float(visible_counts[obj.object_id]) / float(obj.shape.sum())
        boxes.append(
            GroundTruthBox(
                n,
                obj.object_id,
                float(x),
                float(y),
                float(obj.width),
                float(obj.height),
                round(visibility, 4),
            )
        )
    return boxes


# --- files -------------------------------------------------------------------------------------
