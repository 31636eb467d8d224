"""Street scenes: deterministic surveillance clips of walking people, with ground truth (no rclpy).

Where :mod:`tracker_ptz_sim.simulation.scenes` moves textured ellipses over noise, a street scene
looks like a fixed surveillance camera over a plaza: a real background (any image, e.g. the
per-pixel median of a clip from :func:`median_background`, or a procedural paved plaza with a
building, benches and posts), people drawn as articulated figures with a walking gait and
perspective sizes, groups walking side by side, pairs whose paths cross (one hides the other),
people who stop and stand still for a while midway (change detection loses them), advertising
boards that hide a walker completely for a set time (``occluders``, ``occlusion``),
things that move in place (fluttering barrier tape, shimmering foliage, a flickering screen or
lamp), a slow lighting drift, lens blur, sensor noise, JPEG compression and optional camera jitter.

World model: a flat ground seen by a pinhole camera whose focal length is one image width. A
person of 1.7 m whose foot is at image row ``v`` is ``person_height_far`` px tall at
``v = horizon_y * height`` and ``person_height_near`` px at the bottom edge, linear in ``v`` in
between (and beyond); nobody walks above ``horizon_y``. People walk along smooth paths on the
ground in metres at constant speeds in m/s, entering through the left, right or bottom border and
leaving through another one; their gait phase advances with the distance walked (a step is ~0.4 of
the stature). Everything in the scene is ordered by depth: whatever stands nearer the camera (a
larger foot row) is drawn later and hides what is behind it, distractors included.

Ground truth, per frame and person (``object_id`` >= 1): the *visible* box, i.e. the tight box of
the pixels labelled with its id in that frame (clipped by the frame border, nearer people and
nearer distractors), and its visibility, the share of its silhouette's pixels that are visible.
A person with no visible pixel gets no box; a box whose visibility is below ``min_visibility``
has ``conf = 0`` (MOTChallenge's "ignore"). The label images are exact: figures are drawn without
anti-aliasing (lens blur only softens the *rendered* frame). Labels are uint16 to save memory.

Coordinates and files are those of :mod:`~tracker_ptz_sim.simulation.scenes` (image px, origin at
the top-left corner of the top-left pixel; camera jitter shifts the whole world); write and read
street scenes with its :func:`~tracker_ptz_sim.simulation.scene_files.write_scene` and
:func:`~tracker_ptz_sim.simulation.scene_files.load_scene`. :func:`generate_street` returns a
:class:`StreetScene`, which also carries each person's path (:class:`StreetPerson`).

The same :class:`StreetConfig` (and background) always gives bit-identical frames: every random
choice comes from ``numpy.random`` streams spawned from the seed, one per concern (layout,
appearance, background, distractors, sensor), so e.g. adding a walker leaves the background alone.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import ClassVar, Protocol

import cv2
import numpy as np

from tracker_msgs_py.params import check_config
from tracker_ptz_sim.simulation.camera_effects import (
    LINE,
    ONE,
    SHIFT,
    fit_background,
    illumination_gain,
    sensor_effects,
    smooth_noise,
)
from tracker_ptz_sim.simulation.real_people import (
    SETS,
    CutoutLibrary,
    LookChooser,
    RealLook,
    real_sprite,
)
from tracker_ptz_sim.simulation.scenes import (
    GroundTruthBox,
    Scene,
    clip_problems,
    negative_counts,
)

PEOPLE = ("drawn", *SETS)  # StreetConfig.people
STATURE_M = 1.7  # the person height the perspective sizes refer to
STEP_FRACTION = 0.4  # step length / stature


@dataclass(frozen=True)
class StreetConfig:
    """Everything that defines a street scene; the same config always renders the same scene."""

    generator: ClassVar[str] = "street"  # scene.json's "generator" for this kind of config

    width: int = 768  # px
    height: int = 576  # px
    num_frames: int = 300
    fps: float = 10.0
    walkers: int = 4  # people walking alone, kept apart from everybody else
    groups: int = 0  # groups of 2-3 people walking side by side at the same speed
    crossings: int = 0  # pairs whose paths cross at the same time, so one hides the other
    stoppers: int = 0  # people walking alone who stand still for stop_duration midway in view
    stop_duration: float = 5.0  # s
    occluders: int = 0  # boards standing in front of walkers' paths, one per walker (first ones)
    occlusion: float = 1.0  # s, each board hides its walker completely at least this long
    horizon_y: float = 0.25  # fraction of the height: nobody's foot is above this row
    person_height_far: float = 70.0  # px, a 1.7 m person with the foot at horizon_y
    person_height_near: float = 220.0  # px, the same person with the foot at the bottom edge
    speed_range: tuple[float, float] = (0.9, 1.6)  # m/s, one speed per walker/group/crossing
    flutter: int = 2  # strips of red/white barrier tape between two posts, fluttering in the wind
    foliage: int = 1  # bushes whose leaves shimmer
    flicker: int = 1  # rectangles (screen, lamp) whose brightness switches at random frames
    cars: int = 0  # cars driving across the view along the ground (not people: no ground truth)
    shadow: float = 0.3  # darkening under each person's soft ground shadow (background), 0 = none
    illumination_drift: float = 0.05  # relative amplitude of a slow sinusoidal gain
    illumination_period: float = 30.0  # s
    optical_blur: float = 0.6  # px, Gaussian sigma of the lens blur of every rendered frame
    noise_sigma: float = 3.0  # grey levels, Gaussian sensor noise, new every frame
    jpeg_quality: int = 75  # every frame goes through JPEG at this quality; 0 = no compression
    camera_jitter: int = 0  # px, per-frame camera offset drawn uniformly from [-j, j] per axis
    min_visibility: float = 0.25  # boxes less visible than this get conf 0 (ignored)
    # who walks: "drawn" figures, or real people cut out of an annotated clip (real_people), those
    # of its "development" set or of its "held_out" set
    people: str = "drawn"
    seed: int = 0

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        """Why this scene cannot be rendered (empty: it can)."""
        c = self
        problems = clip_problems(c, min_side=64)
        problems += negative_counts(
            c,
            (
                "walkers",
                "groups",
                "crossings",
                "stoppers",
                "flutter",
                "foliage",
                "flicker",
                "cars",
                "camera_jitter",
                "occluders",
            ),
        )
        problems += _perspective_problems(c)
        lo, hi = c.speed_range
        if not (math.isfinite(lo) and math.isfinite(hi) and 0.1 <= lo <= hi <= 10.0):
            problems.append(
                f"speed_range must satisfy 0.1 <= min <= max <= 10, got {c.speed_range}"
            )
        names = ("illumination_period", "optical_blur", "noise_sigma", "stop_duration", "occlusion")
        for name in names:
            value = getattr(c, name)
            if not (math.isfinite(value) and value >= 0):
                problems.append(f"{name} must be a finite number >= 0, got {value}")
        if not 0 <= c.shadow < 1.0:
            problems.append(f"shadow must be in [0, 1), got {c.shadow}")
        if not 0 <= c.illumination_drift < 1.0:
            problems.append(f"illumination_drift must be in [0, 1), got {c.illumination_drift}")
        if not 0 <= c.jpeg_quality <= 100:
            problems.append(f"jpeg_quality must be in [0, 100], got {c.jpeg_quality}")
        if not 0 <= c.min_visibility <= 1:
            problems.append(f"min_visibility must be in [0, 1], got {c.min_visibility}")
        if c.people not in PEOPLE:
            problems.append(f"people must be one of {', '.join(PEOPLE)}, got '{c.people}'")
        return problems


def _perspective_problems(c: StreetConfig) -> list[str]:
    problems = []
    if not 0 <= c.horizon_y <= 0.8:
        problems.append(f"horizon_y must be in [0, 0.8], got {c.horizon_y}")
        return problems
    far, near = c.person_height_far, c.person_height_near
    if not (math.isfinite(far) and math.isfinite(near) and 8 <= far <= near):
        problems.append(f"need 8 <= person_height_far <= person_height_near, got {far}, {near}")
    elif near - far >= (1 - c.horizon_y) * c.height:
        problems.append(
            "person_height_near - person_height_far must be less than the walkable rows "
            f"((1 - horizon_y) * height = {(1 - c.horizon_y) * c.height:g}): the camera must be "
            "above head height"
        )
    elif near > 0.9 * c.height:
        problems.append(f"person_height_near must be <= 0.9 * height, got {near}")
    return problems


# Benchmark scenes (768x576, 300 frames at 10 fps, all distractors, lighting drift, noise, JPEG);
# the seeds are chosen so that somebody is in view in every frame.
STREET_PRESETS: dict[str, StreetConfig] = {
    # 5 people walking alone, never overlapping one another: 1-3 in view at a time.
    "walkers": StreetConfig(walkers=5, seed=13),
    # 2 groups of 2-3 walking together, a pair crossing (one hides the other), 1 walker alone.
    "groups": StreetConfig(walkers=1, groups=2, crossings=1, seed=14),
    # like "walkers", seen by a camera shaking by up to 3 px.
    "shaky": StreetConfig(walkers=5, camera_jitter=3, seed=8),
    # 2 people walking alone and 2 who stop for 5 s midway in view (change detection loses them).
    "stops": StreetConfig(walkers=2, stoppers=2, seed=21),
    # 4 people walking alone, each hidden for 1 s by a board midway through their time in view.
    "occluded": StreetConfig(walkers=4, occluders=4, seed=37),
}


def _real_people_presets() -> dict[str, StreetConfig]:
    """The benchmark's scenes of real people (`real_people`): each kind of scene with the
    development people ("real_...") and with the held-out people ("heldout_...", other seeds).
    People are 60-190 px tall, as tall as vtest.avi's own (cut-outs are scaled up at most 2x). The
    seeds are the first pairs (seed, seed + 1) from 100 on whose layouts have somebody in the
    image in every frame, the development pair first."""
    kinds = {  # kind: (config, development seed, held-out seed)
        "walkers": (StreetConfig(walkers=6), 115, 117),
        "groups": (StreetConfig(walkers=2, groups=2, crossings=1), 115, 117),
        "crossings": (StreetConfig(walkers=2, crossings=3), 117, 120),
        "stops": (StreetConfig(walkers=3, stoppers=2), 118, 130),
        "occluded": (StreetConfig(walkers=5, occluders=5), 108, 117),
        "shaky": (StreetConfig(walkers=6, camera_jitter=3), 127, 143),
    }
    presets = {}
    for kind, (config, development, held_out) in kinds.items():
        for prefix, people, seed in (
            ("real", "development", development),
            ("heldout", "held_out", held_out),
        ):
            presets[f"{prefix}_{kind}"] = replace(
                config, people=people, person_height_far=60.0, person_height_near=190.0, seed=seed
            )
    return presets


REAL_PEOPLE_PRESETS: dict[str, StreetConfig] = _real_people_presets()


@dataclass(frozen=True, eq=False)
class StreetPerson:
    """One person's path through the scene (world px = image px before camera jitter)."""

    object_id: int
    kind: str  # "walker", "stopper", "group" or "crossing"
    unit: int  # members of one group or crossing pair share it
    speed: float  # m/s
    stature: float  # m
    ground: np.ndarray  # (N, 2) foot on the ground, metres (X right, Z away); NaN: off path
    foot: np.ndarray  # (N, 2) world px of the foot (bottom centre of the figure); NaN: off path
    height: np.ndarray  # (N,) px, the person's standing height there; NaN: off path


@dataclass
class StreetScene(Scene):
    """A rendered street scene: a :class:`Scene` plus each person's path."""

    people: list[StreetPerson] = field(default_factory=list)


# --- ground model ------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Ground:
    """The flat ground: image px <-> metres (X right, Z away from the camera) and sizes there."""

    width: int
    height: int
    horizon: float  # px, the highest foot row
    far: float  # px, height of a 1.7 m person at the horizon row
    slope: float  # px of height per px of foot row

    @classmethod
    def of(cls, c: StreetConfig) -> _Ground:
        horizon = c.horizon_y * c.height
        slope = (c.person_height_near - c.person_height_far) / (c.height - horizon)
        return cls(c.width, c.height, horizon, c.person_height_far, slope)

    @property
    def vanishing(self) -> float:
        """Row of the true horizon (where a person would be 0 px tall); -inf without perspective."""
        return self.horizon - self.far / self.slope if self.slope > 0 else -math.inf

    @property
    def focal(self) -> float:
        return float(self.width)

    def person_height(self, v: np.ndarray | float) -> np.ndarray:
        return np.asarray(self.far + self.slope * (np.asarray(v) - self.horizon), float)

    def tilt(self, v: np.ndarray | float) -> np.ndarray:
        """Px per metre in depth over px per metre across, at foot row v (the view's slant)."""
        if self.slope <= 0:
            return np.full(np.shape(v), 0.5)
        return np.clip((np.asarray(v, float) - self.vanishing) / self.focal, 0.05, 1.0)

    def to_image(self, ground: np.ndarray) -> np.ndarray:
        """(..., 2) ground metres -> (..., 2) image px."""
        x_m, z_m = ground[..., 0], ground[..., 1]
        cx = self.width / 2
        if self.slope <= 0:
            s = self.far / STATURE_M
            return np.stack([cx + s * x_m, self.height - s * z_m], axis=-1)
        cam = STATURE_M / self.slope  # camera height, m
        zc = np.maximum(z_m, 1e-3)
        return np.stack(
            [cx + self.focal * x_m / zc, self.vanishing + self.focal * cam / zc], axis=-1
        )

    def to_ground(self, image: np.ndarray) -> np.ndarray:
        """(..., 2) image px (below the vanishing row) -> (..., 2) ground metres."""
        u, v = image[..., 0], image[..., 1]
        cx = self.width / 2
        if self.slope <= 0:
            s = self.far / STATURE_M
            return np.stack([(u - cx) / s, (self.height - v) / s], axis=-1)
        cam = STATURE_M / self.slope
        z_m = self.focal * cam / np.maximum(v - self.vanishing, 1e-6)
        return np.stack([(u - cx) * z_m / self.focal, z_m], axis=-1)

    def boxes(self, foot: np.ndarray, stature: float = STATURE_M) -> np.ndarray:
        """(N, 2) foot px -> (N, 4) generous (x0, y0, x1, y1) boxes of a walking figure."""
        h = self.person_height(foot[:, 1]) * stature / STATURE_M
        return np.stack(
            [
                foot[:, 0] - 0.32 * h,
                foot[:, 1] - 1.03 * h,
                foot[:, 0] + 0.32 * h,
                foot[:, 1] + 0.05 * h,
            ],
            axis=-1,
        )

    def in_view(self, boxes: np.ndarray, margin: float) -> np.ndarray:
        return (
            (boxes[:, 2] > -margin)
            & (boxes[:, 0] < self.width + margin)
            & (boxes[:, 3] > -margin)
            & (boxes[:, 1] < self.height + margin)
        )


# --- paths and layout --------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class _Path:
    points: np.ndarray  # (K, 2) ground metres
    arc: np.ndarray  # (K,) cumulative length, m
    heading: np.ndarray  # (K,) unwrapped direction of travel, rad (0 = +X, pi/2 = away)

    @classmethod
    def through(cls, points: np.ndarray) -> _Path:
        steps = np.diff(points, axis=0)
        arc = np.concatenate([[0.0], np.cumsum(np.hypot(steps[:, 0], steps[:, 1]))])
        angles = np.arctan2(steps[:, 1], steps[:, 0])
        heading = np.unwrap(np.concatenate([angles[:1], angles]))
        return cls(points, arc, heading)

    @property
    def length(self) -> float:
        return float(self.arc[-1])

    def at(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions (M, 2) and headings (M,) at distances s along the path (clamped)."""
        x = np.interp(s, self.arc, self.points[:, 0])
        z = np.interp(s, self.arc, self.points[:, 1])
        return np.stack([x, z], axis=-1), np.interp(s, self.arc, self.heading)


@dataclass(frozen=True, eq=False)
class _Plan:
    """One person's walk: along ``path`` from time ``t0`` at ``speed``, ``offset`` m to its left."""

    path: _Path
    t0: float  # s, when the path's start is passed
    speed: float  # m/s
    offset: float = 0.0
    ahead: float = 0.0  # m, how far ahead of the path position
    stature: float = STATURE_M
    stop_at: float = math.inf  # m along the path where the person stands still ...
    stop_for: float = 0.0  # ... for this many seconds

    def walk(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Ground positions (N, 2, NaN off the path), headings (N,) and distances walked (N,)."""
        s = self.speed * (times - self.t0) + self.ahead
        if self.stop_for > 0:
            standing = self.speed * self.stop_for
            s = np.where(s < self.stop_at, s, np.maximum(s - standing, self.stop_at))
        pos, heading = self.path.at(s)
        left = np.stack([-np.sin(heading), np.cos(heading)], axis=-1)
        pos = pos + self.offset * left
        pos[(s < 0) | (s > self.path.length)] = np.nan
        return pos, heading, s


@dataclass(frozen=True, eq=False)
class _Unit:
    kind: str
    plans: list[_Plan]


def _bezier(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, p3: np.ndarray) -> np.ndarray:
    t = np.linspace(0.0, 1.0, 241)[:, None]
    curve: np.ndarray = (
        (1 - t) ** 3 * p0 + 3 * (1 - t) ** 2 * t * p1 + 3 * (1 - t) * t**2 * p2 + t**3 * p3
    )
    return curve


def _outside(ground: _Ground, point: np.ndarray, direction: np.ndarray, extra: float) -> np.ndarray:
    """March from ``point`` along ``direction`` (ground) until a figure there is out of the image,
    then ``extra`` metres further; NaN if the march would cross the horizon first."""
    horizon_z = float(ground.to_ground(np.array([ground.width / 2, ground.horizon]))[1])
    unit = direction / max(float(np.hypot(*direction)), 1e-9)
    steps = point + np.arange(0, 80, 0.1)[:, None] * unit
    steps = steps[steps[:, 1] > 0.3]
    if not len(steps):
        return np.full(2, np.nan)
    boxes = ground.boxes(ground.to_image(steps))
    out = ~ground.in_view(boxes, 2.0)
    over = steps[:, 1] > horizon_z + 1e-6
    first_out = int(np.argmax(out)) if out.any() else len(steps)
    if first_out == len(steps) or over[: first_out + 1].any():
        return np.full(2, np.nan)
    beyond: np.ndarray = steps[first_out] + extra * unit
    return beyond


def _border_point(rng: np.random.Generator, ground: _Ground, side: str) -> np.ndarray:
    """An image point on the walkable part of a border."""
    W, H, hz = ground.width, ground.height, ground.horizon
    if side == "bottom":
        return np.array([rng.uniform(0.12, 0.88) * W, float(H)])
    v = hz + rng.uniform(0.03, 0.92) ** 1.5 * (H - hz)  # more often in the wider far part
    return np.array([0.0 if side == "left" else float(W), v])


def _outward(ground: _Ground, point: np.ndarray, side: str) -> np.ndarray:
    """Ground direction that leaves the image through ``side`` from the image ``point``."""
    g = ground.to_ground(point)
    if side == "bottom":  # towards the camera, keeping the image column
        nearer = ground.to_ground(point + np.array([0.0, 1.0]))
        towards: np.ndarray = nearer - g
        return towards
    return np.array([-1.0 if side == "left" else 1.0, 0.0])


def _curved_path(rng: np.random.Generator, ground: _Ground, extra: float) -> _Path | None:
    """A smooth path from outside one border to outside another, never above the horizon; half
    of them cross from left to right or back (the long walks), the others come from or go to
    the bottom."""
    sides = ["left", "right", "bottom"]
    across = rng.uniform() < 0.5
    entry = sides[int(rng.integers(2 if across else 3))]
    others = [s for s in sides if s != entry]
    exit_ = others[0 if across else int(rng.integers(2))]  # across: left <-> right
    ends = []
    for side in (entry, exit_):
        point = _border_point(rng, ground, side)
        ends.append(_outside(ground, ground.to_ground(point), _outward(ground, point, side), extra))
    start, end = ends
    if np.isnan(start).any() or np.isnan(end).any():
        return None
    chord = end - start
    normal = np.array([-chord[1], chord[0]]) / max(float(np.hypot(*chord)), 1e-9)
    bends = rng.uniform(-0.15, 0.15, size=2) * float(np.hypot(*chord))
    points = _bezier(
        start, start + chord / 3 + bends[0] * normal, start + 2 * chord / 3 + bends[1] * normal, end
    )
    return _Path.through(points) if _walkable(ground, points) else None


def _walkable(ground: _Ground, points: np.ndarray) -> bool:
    if (points[:, 1] <= 0.3).any():
        return False
    return bool((ground.to_image(points)[:, 1] >= ground.horizon - 1e-6).all())


def _straight_path(
    ground: _Ground, through: np.ndarray, heading: float
) -> tuple[_Path, float] | None:
    """A straight path through ``through`` (ground) with ``heading``, and the distance from its
    start to ``through``."""
    direction = np.array([math.cos(heading), math.sin(heading)])
    start = _outside(ground, through, -direction, 1.5)
    end = _outside(ground, through, direction, 1.5)
    if np.isnan(start).any() or np.isnan(end).any():
        return None
    points = start + np.linspace(0, 1, 121)[:, None] * (end - start)
    return _Path.through(points), float(np.hypot(*(through - start)))


@dataclass
class _Layout:
    """The people placed so far and the approximate boxes they take, frame by frame."""

    config: StreetConfig
    ground: _Ground
    times: np.ndarray  # (N,) s
    units: list[_Unit] = field(default_factory=list)
    taken: list[np.ndarray] = field(default_factory=list)  # (N, 4) boxes, NaN when out of view

    def boxes(self, plan: _Plan) -> np.ndarray:
        pos, _, _ = plan.walk(self.times)
        boxes = self.ground.boxes(self.ground.to_image(pos), plan.stature)
        margin = self.config.camera_jitter + 2.0
        boxes[~self.ground.in_view(boxes, margin)] = np.nan
        return boxes

    def fits(self, unit: _Unit) -> bool:
        """Every member visible long enough, and nobody's box touching anyone else's."""
        need = max(1, min(self.config.num_frames // 2, round(4 * self.config.fps)))
        candidate = [self.boxes(p) for p in unit.plans]
        if any(int((~np.isnan(b[:, 0])).sum()) < need for b in candidate):
            return False
        return not any(_overlap(a, b) for a in candidate for b in self.taken)

    def add(self, unit: _Unit) -> None:
        self.units.append(unit)
        self.taken += [self.boxes(p) for p in unit.plans]


def _overlap(a: np.ndarray, b: np.ndarray, margin: float = 3.0) -> bool:
    with np.errstate(invalid="ignore"):
        hit = (
            (a[:, 0] < b[:, 2] + margin)
            & (b[:, 0] < a[:, 2] + margin)
            & (a[:, 1] < b[:, 3] + margin)
            & (b[:, 1] < a[:, 3] + margin)
        )
    return bool(hit.any())


def _stature(rng: np.random.Generator) -> float:
    return float(np.clip(rng.normal(1.72, 0.07), 1.55, 1.92))


def _walker_unit(rng: np.random.Generator, layout: _Layout, centre: float) -> _Unit | None:
    path = _curved_path(rng, layout.ground, 1.0)
    if path is None:
        return None
    speed = float(rng.uniform(*layout.config.speed_range))
    plan = _Plan(path, centre - path.length / speed / 2, speed, stature=_stature(rng))
    return _Unit("walker", [plan])


def _stopper_unit(rng: np.random.Generator, layout: _Layout, centre: float) -> _Unit | None:
    """A walker who stands still for ``stop_duration`` at a point of the path in the middle half
    of the stretch seen in the image."""
    walker = _walker_unit(rng, layout, centre)
    if walker is None:
        return None
    plan = walker.plans[0]
    seen = ~np.isnan(layout.boxes(plan)[:, 0])
    if not seen.any():
        return None
    walked = plan.walk(layout.times)[2][seen]
    stop_at = float(np.quantile(walked, rng.uniform(0.25, 0.75)))
    duration = layout.config.stop_duration
    t0 = plan.t0 - duration / 2  # still centred on ``centre``
    return _Unit(
        "stopper",
        [
            _Plan(
                plan.path, t0, plan.speed, stature=plan.stature, stop_at=stop_at, stop_for=duration
            )
        ],
    )


def _group_unit(rng: np.random.Generator, layout: _Layout, centre: float) -> _Unit | None:
    path = _curved_path(rng, layout.ground, 2.5)
    if path is None:
        return None
    speed = float(rng.uniform(*layout.config.speed_range))
    size = 2 if rng.uniform() < 0.6 else 3
    spacing = rng.uniform(0.25, 0.5, size=size - 1) + 0.42  # shoulder to shoulder gap + body width
    offsets = np.concatenate([[0.0], np.cumsum(spacing)])
    offsets -= offsets.mean()
    t0 = centre - path.length / speed / 2
    plans = [
        _Plan(path, t0, speed, float(o), float(rng.uniform(-0.25, 0.25)), _stature(rng))
        for o in offsets
    ]
    for plan in plans:
        pos = plan.walk(layout.times)[0]
        if not _walkable(layout.ground, pos[~np.isnan(pos[:, 0])]):
            return None
    return _Unit("group", plans)


def _crossing_unit(rng: np.random.Generator, layout: _Layout, centre: float) -> _Unit | None:
    """Two people passing the same place at the same time: the farther one is hidden."""
    g = layout.ground
    meet_px = np.array(
        [
            rng.uniform(0.3, 0.7) * g.width,
            g.horizon + rng.uniform(0.35, 0.75) * (g.height - g.horizon),
        ]
    )
    meet = g.to_ground(meet_px)
    behind = meet + np.array([rng.uniform(-0.3, 0.3), rng.uniform(0.5, 1.0)])
    heading = rng.uniform(-0.45, 0.45) + (math.pi if rng.uniform() < 0.5 else 0.0)
    other = heading + math.pi + rng.choice([-1.0, 1.0]) * rng.uniform(0.35, 0.8)
    plans = []
    for point, angle in ((meet, heading), (behind, other)):
        made = _straight_path(g, point, angle)
        if made is None:
            return None
        path, distance = made
        speed = float(rng.uniform(*layout.config.speed_range))
        plans.append(_Plan(path, centre - distance / speed, speed, stature=_stature(rng)))
    return _Unit("crossing", plans)


UnitMaker = Callable[[np.random.Generator, _Layout, float], "_Unit | None"]


def _place(
    rng: np.random.Generator, layout: _Layout, make: UnitMaker, slot: tuple[float, float]
) -> None:
    """Try ``make`` at times in ``slot`` (fractions of the clip), then anywhere; a unit that finds
    no free place is left out."""
    duration = layout.config.num_frames / layout.config.fps
    for attempt in range(120):
        lo, hi = slot if attempt < 60 else (0.0, 1.0)
        unit = make(rng, layout, float(rng.uniform(lo, hi)) * duration)
        if unit is not None and layout.fits(unit):
            layout.add(unit)
            return


def _layout(rng: np.random.Generator, config: StreetConfig, ground: _Ground) -> list[_Unit]:
    layout = _Layout(config, ground, np.arange(config.num_frames) / config.fps)
    for _ in range(config.crossings):
        _place(rng, layout, _crossing_unit, (0.3, 0.7))
    makers: list[UnitMaker] = []
    makers += [_group_unit] * config.groups + [_walker_unit] * config.walkers
    makers += [_stopper_unit] * config.stoppers
    slots = rng.permutation(len(makers))
    for maker, slot in zip(makers, slots, strict=True):
        lo = 0.1 + 0.8 * slot / len(makers)  # spread over the clip, overlapping in time
        _place(rng, layout, maker, (lo, lo + 0.8 / len(makers)))
    return layout.units


# --- people: look, pose, sprite ----------------------------------------------------------------


def _palette(text: str) -> np.ndarray:
    """BGR colours written as "b g r, b g r, ..." -> (K, 3) float32."""
    return np.array([c.split() for c in text.split(",")], np.float32)


_SHIRTS = _palette(
    "30 30 32, 45 40 40, 80 45 30, 140 95 60, 120 120 122, 185 185 188, 220 222 225, 150 180 200,"
    "40 40 130, 50 50 185, 55 105 95, 70 115 60, 40 70 110, 170 110 50, 60 180 215, 165 135 210,"
    "95 80 70, 30 60 90"
)
_TROUSERS = _palette(
    "130 85 55, 90 55 35, 30 30 35, 95 95 100, 120 160 180, 40 55 75, 60 60 65, 150 150 150"
)
_SHOES = _palette("25 25 28, 30 50 80, 215 215 220, 60 60 60")
_SKINS = _palette("150 180 225, 125 160 210, 95 135 190, 65 95 145, 45 65 100")
_HAIRS = _palette("20 20 25, 30 40 60, 45 65 105, 95 145 195, 160 160 165, 25 30 40")

# part ids of the sprite's part image (0 = not the person); far-side parts are shaded darker
HAIR, SKIN, SHIRT, TROUSERS, SHOES = 1, 2, 3, 4, 5
FAR = 5  # far-side part = near-side part + FAR


@dataclass(frozen=True, eq=False)
class _Look:
    lut: np.ndarray  # (11, 3) float32 colour of each part id
    stripe: np.ndarray | None  # (3,) colour of shirt stripes, or None
    long_sleeves: bool
    long_hair: bool
    texture: np.ndarray  # (8, 5) float32 fabric texture, upsampled to the sprite
    phase: float  # gait phase at the path's start, cycles
    cycle: float  # m walked per gait cycle (two steps)


def _pick(rng: np.random.Generator, palette: np.ndarray, jitter: float = 10.0) -> np.ndarray:
    colour = palette[int(rng.integers(len(palette)))] + rng.normal(0, jitter, 3)
    picked: np.ndarray = np.clip(colour, 8, 245).astype(np.float32)
    return picked


def _random_look(rng: np.random.Generator, stature: float, near_background: np.ndarray) -> _Look:
    """Clothes and hair; some people wear colours close to the background behind them."""
    shirt, trousers = _pick(rng, _SHIRTS), _pick(rng, _TROUSERS)
    camouflage = rng.uniform()
    if camouflage < 0.25:
        shirt = np.clip(near_background + rng.normal(0, 8, 3), 8, 245).astype(np.float32)
    elif camouflage < 0.4:
        trousers = np.clip(near_background + rng.normal(0, 8, 3), 8, 245).astype(np.float32)
    near = [_pick(rng, _HAIRS, 6), _pick(rng, _SKINS, 6), shirt, trousers, _pick(rng, _SHOES, 5)]
    lut = np.zeros((2 * FAR + 1, 3), np.float32)
    for part, colour in enumerate(near, start=1):
        lut[part] = colour
        lut[part + FAR] = colour * 0.72
    stripe = _pick(rng, _SHIRTS) if rng.uniform() < 0.2 else None
    return _Look(
        lut,
        stripe,
        bool(rng.uniform() < 0.6),
        bool(rng.uniform() < 0.3),
        rng.uniform(-1, 1, size=(8, 5)).astype(np.float32),
        float(rng.uniform()),
        2 * STEP_FRACTION * stature * float(rng.uniform(0.92, 1.08)),
    )


def _skeleton(phase: float) -> dict[str, np.ndarray]:
    """Joints in body units (forward, left, up; stature = 1) at gait phase ``phase`` (cycles)."""
    psi = 2 * math.pi * phase
    j: dict[str, np.ndarray] = {}
    for side, sign, angle in (("r", -1.0, psi), ("l", 1.0, psi + math.pi)):
        hip_angle = math.radians(21) * math.sin(angle)
        knee = math.radians(5) + math.radians(45) * max(0.0, math.cos(angle))  # bent in swing
        j["hip" + side] = hip = np.array([0.0, sign * 0.06, 0.5])
        j["knee" + side] = k = hip + 0.245 * np.array(
            [math.sin(hip_angle), 0, -math.cos(hip_angle)]
        )
        shin = hip_angle - knee
        j["ankle" + side] = a = k + 0.235 * np.array([math.sin(shin), 0, -math.cos(shin)])
        j["toe" + side] = a + np.array([0.075, 0.0, -0.015])
        arm = -math.radians(22) * math.sin(angle)
        j["shoulder" + side] = s = np.array([0.0, sign * 0.135, 0.80])
        j["elbow" + side] = e = s + 0.17 * np.array([math.sin(arm), sign * 0.08, -math.cos(arm)])
        fore = arm + math.radians(12) + math.radians(18) * max(0.0, math.sin(-arm))
        j["wrist" + side] = e + 0.155 * np.array([math.sin(fore), 0, -math.cos(fore)])
    bob = 0.03 - min(j["ankler"][2], j["anklel"][2])  # the lower foot stands on the ground
    for p in j.values():
        p[2] += bob
    j["neck"] = np.array([0.01, 0.0, 0.80 + bob])
    j["head"] = np.array([0.02, 0.0, 0.932 + bob])
    return j


@dataclass(frozen=True)
class _View:
    """How body units map to image px for one figure in one frame."""

    u: float  # foot, image px
    v: float
    h: float  # stature, px
    cos: float  # of the heading on the ground
    sin: float
    tilt: float  # image px per px of depth

    def __call__(self, p: np.ndarray) -> tuple[float, float]:
        f, left, z = float(p[0]), float(p[1]), float(p[2])
        depth = f * self.sin + left * self.cos
        return self.u + self.h * (f * self.cos - left * self.sin), self.v - self.h * (
            z + self.tilt * depth
        )


@dataclass
class _Sprite:
    parts: np.ndarray  # (h, w) uint8 part ids, 0 = not the person
    x0: int  # image px of the part image's top-left corner
    y0: int

    def point(self, xy: tuple[float, float]) -> tuple[int, int]:
        return (round((xy[0] - self.x0) * ONE), round((xy[1] - self.y0) * ONE))


def _limb(
    s: _Sprite, a: tuple[float, float], b: tuple[float, float], part: int, width: float
) -> None:
    cv2.line(s.parts, s.point(a), s.point(b), part, max(1, round(width)), LINE, SHIFT)


def _outline(view: _View, levels: tuple[tuple[float, float], ...], half_d: float) -> np.ndarray:
    """Image points of a body section: rectangles (half width, ``half_d`` half depth) at the
    heights of ``levels`` ((z, half width), ...); their convex hull is the section's outline."""
    corners = [
        view(np.array([fd * half_d, side * w, z]))
        for z, w in levels
        for side in (-1, 1)
        for fd in (-1, 1)
    ]
    return np.array(corners)


def _fill(s: _Sprite, outline: np.ndarray, part: int) -> None:
    hull = cv2.convexHull(np.round((outline - (s.x0, s.y0)) * ONE).astype(np.int32))
    cv2.fillConvexPoly(s.parts, hull, part, LINE, SHIFT)


def _draw_leg(s: _Sprite, j: dict[str, np.ndarray], view: _View, side: str, far: bool) -> None:
    h, off = view.h, FAR if far else 0
    hip, knee, ankle = view(j["hip" + side]), view(j["knee" + side]), view(j["ankle" + side])
    _limb(s, hip, knee, TROUSERS + off, 0.09 * h)
    _limb(s, knee, ankle, TROUSERS + off, 0.065 * h)
    _limb(s, ankle, view(j["toe" + side]), SHOES + off, 0.04 * h)


def _draw_arm(
    s: _Sprite, j: dict[str, np.ndarray], view: _View, side: str, far: bool, look: _Look
) -> None:
    h, off = view.h, FAR if far else 0
    shoulder, elbow, wrist = (
        view(j["shoulder" + side]),
        view(j["elbow" + side]),
        view(j["wrist" + side]),
    )
    _limb(s, shoulder, elbow, SHIRT + off, 0.06 * h)
    _limb(s, elbow, wrist, (SHIRT if look.long_sleeves else SKIN) + off, 0.048 * h)
    cv2.circle(s.parts, s.point(wrist), round(0.025 * h * ONE), SKIN + off, -1, LINE, SHIFT)


def _draw_head(s: _Sprite, j: dict[str, np.ndarray], view: _View, look: _Look) -> None:
    h = view.h
    neck_width = 0.045 * h
    neck_bottom = j["neck"] + np.array([0, 0, 0.03 + 0.5 * neck_width / h])  # cap above the shirt
    _limb(s, view(neck_bottom), view(j["head"] + np.array([0, 0, -0.04])), SKIN, neck_width)
    centre = view(j["head"])
    half_w = h * math.hypot(0.058 * view.cos, 0.05 * view.sin)
    axes = (round(half_w * ONE), round(0.068 * h * ONE))
    facing = -view.sin  # 1 walking towards the camera, -1 away
    if look.long_hair and facing < 0.5:  # hanging down the back
        back = view(j["head"] + np.array([-0.03, 0, -0.06]))
        long_axes = (round(1.05 * half_w * ONE), round(0.085 * h * ONE))
        cv2.ellipse(s.parts, s.point(back), long_axes, 0, 0, 360, HAIR, -1, LINE, SHIFT)
    elif look.long_hair:  # seen from the front: beside the face
        axes = (round(1.15 * half_w * ONE), round(0.07 * h * ONE))
    cv2.ellipse(s.parts, s.point(centre), axes, 0, 0, 360, HAIR, -1, LINE, SHIFT)
    if facing > -0.6:
        face = (centre[0] + 0.022 * h * view.cos, centre[1] + 0.012 * h)
        face_axes = (round(0.85 * half_w * ONE), round(0.055 * h * ONE))
        cv2.ellipse(s.parts, s.point(face), face_axes, 0, 0, 360, SKIN, -1, LINE, SHIFT)
        cap = (centre[0] - 0.006 * h * view.cos, centre[1] - 0.02 * h)
        cap_axes = (round(1.02 * half_w * ONE), round(0.05 * h * ONE))
        cv2.ellipse(s.parts, s.point(cap), cap_axes, 0, 180, 360, HAIR, -1, LINE, SHIFT)


def _sprite_frame(view: _View, joints: dict[str, np.ndarray]) -> _Sprite:
    """An empty part image holding the whole figure: the joints plus the widest part around."""
    points = np.array([view(p) for p in joints.values()])
    pad = 0.15 * view.h + 3  # the head and torso reach this far beyond their joints
    x0, y0 = (math.floor(c - pad) for c in points.min(axis=0))
    x1, y1 = (math.ceil(c + pad) for c in points.max(axis=0))
    return _Sprite(np.zeros((y1 - y0, x1 - x0), np.uint8), x0, y0)


def _figure(look: _Look, phase: float, view: _View) -> _Sprite:
    """The part image of a walking person (see the part ids)."""
    j = _skeleton(phase)
    s = _sprite_frame(view, j)
    far, near = ("l", "r") if view.cos >= 0 else ("r", "l")  # walking right, the left is away
    _draw_arm(s, j, view, far, True, look)
    _draw_leg(s, j, view, far, True)
    bob = j["neck"][2] - 0.8
    _fill(s, _outline(view, ((0.43 + bob, 0.1), (0.53 + bob, 0.105)), 0.07), TROUSERS)
    torso = ((0.5 + bob, 0.105), (0.77 + bob, 0.135), (0.815 + bob, 0.09))
    _fill(s, _outline(view, torso, 0.075), SHIRT)
    _draw_leg(s, j, view, near, False)
    _draw_arm(s, j, view, near, False, look)
    _draw_head(s, j, view, look)
    return s


def _colour(look: _Look, sprite: _Sprite, view: _View) -> tuple[np.ndarray, np.ndarray]:
    """The sprite's BGR pixels (float32) and mask: part colours, stripes, fabric and shading."""
    parts = sprite.parts
    hh, w = parts.shape
    colour = look.lut[parts]
    if look.stripe is not None:
        rows = (np.arange(hh) + sprite.y0 - view.v) / max(0.045 * view.h, 1.5)
        stripes = (np.floor(rows).astype(int) % 2 == 1)[:, None] & (parts == SHIRT)
        colour[stripes] = look.stripe
    fabric = cv2.resize(look.texture, (w, hh), interpolation=cv2.INTER_LINEAR)
    clothes = (
        (parts == SHIRT) | (parts == TROUSERS) | (parts == SHIRT + FAR) | (parts == TROUSERS + FAR)
    )
    xs = (np.arange(w) - (view.u - sprite.x0)) / max(0.3 * view.h, 1.0)
    shade = (1.0 - 0.12 * np.clip(xs, -1, 1))[None, :] * np.ones((hh, 1), np.float32)
    shade = shade * (1.0 + 0.08 * fabric * clothes)
    return colour * shade[:, :, None].astype(np.float32), parts > 0


# --- compositing --------------------------------------------------------------------------------


def _composite(
    canvas: np.ndarray,
    label: np.ndarray,
    patch: np.ndarray,
    mask: np.ndarray,
    x: int,
    y: int,
    ident: int,
    alpha: np.ndarray | None = None,
) -> tuple[int, int, int, int] | None:
    """Paste ``patch`` where ``mask`` at (x, y), clipped (blended by ``alpha`` where given: the
    soft edge of a cut-out); set ``label`` to ``ident`` where ``mask``. Returns the image
    rectangle (x0, y0, x1, y1) it touched, or None when fully outside."""
    H, W = canvas.shape[:2]
    h, w = mask.shape
    x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + w, W), min(y + h, H)
    if x1 <= x0 or y1 <= y0:
        return None
    sub = mask[y0 - y : y1 - y, x0 - x : x1 - x]
    pixels = patch[y0 - y : y1 - y, x0 - x : x1 - x]
    if alpha is None:
        canvas[y0:y1, x0:x1][sub] = np.clip(pixels[sub], 0, 255)
    else:
        a = alpha[y0 - y : y1 - y, x0 - x : x1 - x, None]
        under = canvas[y0:y1, x0:x1].astype(np.float32)
        canvas[y0:y1, x0:x1] = np.clip(np.rint(a * pixels + (1 - a) * under), 0, 255)
    label[y0:y1, x0:x1][sub] = ident
    return x0, y0, x1, y1


# --- distractors ---------------------------------------------------------------------------------


class _Drawable(Protocol):
    depth: float  # world px row of its foot: larger = nearer, drawn later

    def draw(self, canvas: np.ndarray, label: np.ndarray, n: int, dx: int, dy: int) -> None: ...


def _smooth_wind(rng: np.random.Generator, n: int, fps: float) -> np.ndarray:
    """Gusts: low-pass random plus a sine, roughly in [-1, 1]."""
    gust = np.zeros(n)
    value = 0.0
    for k, e in enumerate(rng.standard_normal(n)):
        value = 0.75 * value + 0.45 * e
        gust[k] = value
    t = np.arange(n) / fps
    return 0.6 * gust + 0.5 * np.sin(2 * math.pi * rng.uniform(0.4, 1.2) * t + rng.uniform(0, 6.3))


@dataclass(eq=False)
class _Tape:
    """Red and white barrier tape between two posts, fluttering in the wind."""

    depth: float
    posts: tuple[np.ndarray, np.ndarray]  # world px of each post's foot
    post_px: tuple[float, float]  # px per metre at each post
    wind: np.ndarray  # (N,)
    ripple: np.ndarray  # (N,) phase of a travelling ripple
    twist: np.ndarray  # (N,)

    def _line(self, n: int) -> np.ndarray:
        (a, b), (pa, pb) = self.posts, self.post_px
        s = np.linspace(0, 1, max(8, int(np.hypot(*(b - a)) / 5)))[:, None]
        scale = (1 - s) * pa + s * pb
        base = (1 - s) * (a - [0, 0.95 * pa]) + s * (b - [0, 0.95 * pb])
        bell = np.sin(math.pi * s)
        lift = (
            0.06 + 0.14 * self.wind[n] * bell + 0.05 * np.sin(2 * math.pi * 2 * s - self.ripple[n])
        )
        points: np.ndarray = base + np.hstack([np.zeros_like(s), lift * bell * scale])
        return points

    def draw(self, canvas: np.ndarray, label: np.ndarray, n: int, dx: int, dy: int) -> None:
        line = self._line(n) + (dx, dy)
        posts = [(foot + (dx, dy), px) for foot, px in zip(self.posts, self.post_px, strict=True)]
        tops = np.array([foot - (0, px) for foot, px in posts])
        pad = 4 + 0.1 * max(self.post_px)

        def paint(region: np.ndarray, mask: np.ndarray, origin: np.ndarray) -> None:
            for foot, px in posts:
                width = max(1, round(0.06 * px))
                for target, value in ((region, (60, 90, 200)), (mask, 1)):
                    top, bottom = _pt(foot - (0, px) - origin), _pt(foot - origin)
                    cv2.line(target, top, bottom, value, width, LINE, SHIFT)
            self._stripes(region, mask, line - origin, n)

        _paint_region(canvas, label, np.vstack([line, tops, [p for p, _ in posts]]), pad, paint)

    def _stripes(self, region: np.ndarray, mask: np.ndarray, line: np.ndarray, n: int) -> None:
        """The tape along ``line``: red and white every 25 cm, thinner where it twists."""
        k = np.arange(len(line))
        px = np.interp(k, [0, len(line) - 1], self.post_px)  # px per metre along the tape
        thick = np.maximum(1, np.round(0.06 * px * np.abs(np.cos(self.twist[n] + 3 * k / len(k)))))
        metres = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(line, axis=0).T) / px[1:])])
        for i in range(len(line) - 1):
            colour = (40, 40, 205) if int(metres[i] / 0.25) % 2 == 0 else (235, 235, 235)
            p, q = _pt(line[i]), _pt(line[i + 1])
            cv2.line(region, p, q, colour, int(thick[i]), LINE, SHIFT)
            cv2.line(mask, p, q, 1, int(thick[i]), LINE, SHIFT)


def _pt(xy: np.ndarray) -> tuple[int, int]:
    return (round(float(xy[0]) * ONE), round(float(xy[1]) * ONE))


def _paint_region(
    canvas: np.ndarray,
    label: np.ndarray,
    points: np.ndarray,
    pad: float,
    paint: Callable[[np.ndarray, np.ndarray, np.ndarray], None],
) -> None:
    """Run ``paint`` on a copy of the canvas around ``points`` and a mask, then write both back
    (the masked pixels become background, label 0)."""
    H, W = canvas.shape[:2]
    x0 = max(0, math.floor(points[:, 0].min() - pad))
    y0 = max(0, math.floor(points[:, 1].min() - pad))
    x1 = min(W, math.ceil(points[:, 0].max() + pad))
    y1 = min(H, math.ceil(points[:, 1].max() + pad + 1))
    if x1 <= x0 or y1 <= y0:
        return
    region = np.ascontiguousarray(canvas[y0:y1, x0:x1])
    mask = np.zeros(region.shape[:2], np.uint8)
    paint(region, mask, np.array([x0, y0], float))
    canvas[y0:y1, x0:x1] = region
    label[y0:y1, x0:x1][mask > 0] = 0


@dataclass(eq=False)
class _Foliage:
    """A bush whose leaves shimmer: texture and outline shift by a pixel or two every frame."""

    depth: float
    x: int  # world px of the top-left corner of the drawn area
    y: int
    texture: np.ndarray  # (h + 2m, w + 2m, 3) float32 leaves
    field_: np.ndarray  # (h + 2m, w + 2m) float32 shape field, > 0.5 = leaves
    shifts: np.ndarray  # (N, 2, 2) int: texture and shape offsets per frame
    margin: int

    def draw(self, canvas: np.ndarray, label: np.ndarray, n: int, dx: int, dy: int) -> None:
        m = self.margin
        h, w = self.field_.shape[0] - 2 * m, self.field_.shape[1] - 2 * m
        (tx, ty), (sx, sy) = self.shifts[n]
        patch = self.texture[m + ty : m + ty + h, m + tx : m + tx + w]
        mask = self.field_[m + sy : m + sy + h, m + sx : m + sx + w] > 0.5
        _composite(canvas, label, patch, mask, self.x + dx, self.y + dy, 0)


@dataclass(eq=False)
class _Flicker:
    """A screen or lamp whose brightness jumps between two levels at random frames."""

    depth: float
    x: int
    y: int
    dim: np.ndarray  # (h, w, 3) float32
    bright: np.ndarray
    on: np.ndarray  # (N,) bool

    def draw(self, canvas: np.ndarray, label: np.ndarray, n: int, dx: int, dy: int) -> None:
        patch = self.bright if self.on[n] else self.dim
        mask = np.ones(patch.shape[:2], bool)
        _composite(canvas, label, patch, mask, self.x + dx, self.y + dy, 0)


@dataclass(eq=False)
class _Board:
    """An advertising board standing on the ground, parallel to the image: opaque down to the
    ground, so whatever walks behind it is hidden."""

    depth: float
    x: int
    y: int
    look: np.ndarray  # (h, w, 3) float32

    def draw(self, canvas: np.ndarray, label: np.ndarray, n: int, dx: int, dy: int) -> None:
        mask = np.ones(self.look.shape[:2], bool)
        _composite(canvas, label, self.look, mask, self.x + dx, self.y + dy, 0)


def _ground_spot(rng: np.random.Generator, ground: _Ground, lo: float, hi: float) -> np.ndarray:
    """A random image point on the walkable ground, rows between fractions lo and hi of it."""
    return np.array(
        [
            rng.uniform(0.05, 0.95) * ground.width,
            ground.horizon + rng.uniform(lo, hi) * (ground.height - ground.horizon),
        ]
    )


def _make_tape(rng: np.random.Generator, ground: _Ground, n: int, fps: float) -> _Tape:
    a = _ground_spot(rng, ground, 0.15, 0.6)
    ga = ground.to_ground(a)
    gb = ga + np.array([rng.uniform(2.5, 5.0) * rng.choice([-1.0, 1.0]), rng.uniform(-1.0, 1.0)])
    b = ground.to_image(gb)
    b[1] = max(b[1], ground.horizon)
    px = tuple(float(ground.person_height(p[1])) / STATURE_M for p in (a, b))
    twist = np.cumsum(rng.normal(0, 0.5, n))
    return _Tape(
        float(max(a[1], b[1])),
        (a, b),
        (px[0], px[1]),
        _smooth_wind(rng, n, fps),
        np.cumsum(rng.uniform(0.5, 1.5, n)),
        twist,
    )


def _make_foliage(rng: np.random.Generator, ground: _Ground, n: int) -> _Foliage:
    foot = _ground_spot(rng, ground, 0.05, 0.9)
    px = float(ground.person_height(foot[1])) / STATURE_M
    w = max(8, round(rng.uniform(1.2, 2.2) * px))
    h = max(6, round(rng.uniform(0.8, 1.4) * px))
    m = 3
    shape = (h + 2 * m, w + 2 * m)
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]].astype(np.float32)
    r = ((xx - shape[1] / 2) / (w / 2)) ** 2 + ((yy - shape[0] / 2) / (h / 2)) ** 2
    field_ = 1.0 - 0.6 * r + 0.25 * smooth_noise(rng, shape, max(1.0, px * 0.05))
    base = np.array([rng.uniform(30, 60), rng.uniform(95, 140), rng.uniform(50, 90)], np.float32)
    leaves = (
        smooth_noise(rng, shape, 0.8, 3) * 0.5
        + smooth_noise(rng, shape, max(1.0, px * 0.04), 1)[:, :, None]
    )
    texture = base * (1.0 + 0.28 * leaves)
    shifts = rng.integers(-2, 3, size=(n, 2, 2))
    shifts[:, 1] = np.clip(shifts[:, 1], -1, 1)
    return _Foliage(
        float(foot[1]),
        round(foot[0] - shape[1] / 2) + m,
        round(foot[1]) - h,
        texture.astype(np.float32),
        field_.astype(np.float32),
        shifts,
        m,
    )


def _make_flicker(rng: np.random.Generator, ground: _Ground, n: int) -> _Flicker:
    W, H = ground.width, ground.height
    w, h = round(rng.uniform(0.04, 0.08) * W), round(rng.uniform(0.03, 0.06) * H)
    top = max(2.0, ground.horizon - h - 0.04 * H)
    y = round(rng.uniform(0.02 * H, top)) if top > 0.02 * H else round(rng.uniform(0, 0.4) * H)
    x = round(rng.uniform(0.02, 0.98) * W - w / 2)
    shading = (1.0 - 0.15 * np.linspace(0, 1, h))[:, None, None].astype(np.float32)
    tint = np.array([230, 215, 190] if rng.uniform() < 0.5 else [150, 215, 245], np.float32)
    texture = 1.0 + 0.05 * smooth_noise(rng, (h, w), 1.0)[:, :, None]
    dim = np.array([55, 55, 60], np.float32) * shading * texture
    bright = tint * shading * texture
    on = np.cumsum(rng.uniform(size=n) < 0.15) % 2 == 1
    return _Flicker(float(y + h), x, y, dim.astype(np.float32), bright.astype(np.float32), on)


@dataclass(eq=False)
class _Car:
    """A car driving across the view along one row of the ground, at a constant speed."""

    depth: float
    y: int  # top row of its picture
    x: np.ndarray  # (N,) left column of its picture per frame
    look: np.ndarray  # (h, w, 3) float32
    mask: np.ndarray  # (h, w) bool

    def draw(self, canvas: np.ndarray, label: np.ndarray, n: int, dx: int, dy: int) -> None:
        _composite(canvas, label, self.look, self.mask, int(self.x[n]) + dx, self.y + dy, 0)


CAR_LENGTH_M, CAR_HEIGHT_M, WHEEL_RADIUS_M = 4.3, 1.45, 0.33
CAR_COLOURS = ((40, 40, 170), (150, 90, 30), (185, 185, 190), (30, 30, 35), (225, 225, 230))


def _make_car(rng: np.random.Generator, ground: _Ground, n: int, fps: float) -> _Car:
    """A side view of a car (body, windows, wheels) sized for its row, entering at one side in
    the first half of the scene at 5-9 m/s and leaving at the other."""
    W, H = ground.width, ground.height
    foot = rng.uniform(ground.horizon + 0.3 * (H - ground.horizon), 0.95 * H)
    metre = float(ground.person_height(foot)) / STATURE_M
    w, h = round(CAR_LENGTH_M * metre), round(CAR_HEIGHT_M * metre)
    body = np.array(CAR_COLOURS[int(rng.integers(len(CAR_COLOURS)))], np.float32)
    look = np.empty((h, w, 3), np.float32)
    look[:] = body * (1.0 + 0.04 * smooth_noise(rng, (h, w), 2.0))[:, :, None]
    mask = np.zeros((h, w), np.uint8)
    roof = [(0.22 * w, 0.0), (0.72 * w, 0.0), (0.85 * w, 0.42 * h), (0.1 * w, 0.42 * h)]
    cv2.fillPoly(mask, [np.round(roof).astype(np.int32)], 1)
    cv2.rectangle(mask, (0, round(0.4 * h)), (w - 1, round(0.82 * h)), 1, -1)
    glass = np.zeros((h, w), np.uint8)
    pane = [(0.26 * w, 0.06 * h), (0.69 * w, 0.06 * h), (0.78 * w, 0.38 * h), (0.16 * w, 0.38 * h)]
    cv2.fillPoly(glass, [np.round(pane).astype(np.int32)], 1)
    look[glass > 0] = (70, 55, 45)
    radius = max(2, round(WHEEL_RADIUS_M * metre))
    for centre in (0.2 * w, 0.8 * w):
        cv2.circle(mask, (round(centre), h - radius - 1), radius, 1, -1)
        wheel = np.zeros((h, w), np.uint8)
        cv2.circle(wheel, (round(centre), h - radius - 1), radius, 1, -1)
        look[wheel > 0] = (25, 25, 25)
    speed = rng.uniform(5.0, 9.0) * metre / fps  # px per frame
    start = rng.uniform(0, 0.5) * n
    rightward = rng.uniform() < 0.5
    travelled = (np.arange(n) - start) * speed
    x = np.where(rightward, -w + travelled, W - travelled)
    return _Car(float(foot), round(foot - h), np.round(x).astype(np.int64), look, mask > 0)


BOARD_GAP_M = 0.6  # how far in front of the walker's nearest point in the hidden stretch
BOARD_HEIGHT_M = 2.5
BODY_HALF_WIDTH = 0.25  # of the stature in px: a walking figure's half width, limbs included


def _make_board(
    rng: np.random.Generator, ground: _Ground, person: _Person, config: StreetConfig
) -> _Board | None:
    """A board in front of ``person`` midway through its time in view, as wide as the stretch it
    walks in ``config.occlusion`` seconds plus its body, so it is hidden that long; None when the
    person is in view too briefly."""
    seen = np.flatnonzero(person.present)
    half = round(config.occlusion * config.fps / 2)
    if len(seen) < 2 * half + 2 * round(config.fps):
        return None
    middle = int(seen[len(seen) // 2])
    hidden = np.arange(middle - half, middle + half + 1)
    foot, height = person.info.foot[hidden], person.info.height[hidden]
    near = ground.to_ground(np.array([ground.width / 2, float(foot[:, 1].max())]))[1]
    bottom = float(ground.to_image(np.array([0.0, max(near - BOARD_GAP_M, 1.0)]))[1])
    px_per_m = float(ground.person_height(bottom)) / STATURE_M
    top = min(bottom - BOARD_HEIGHT_M * px_per_m, float((foot[:, 1] - 1.05 * height).min()))
    reach = BODY_HALF_WIDTH * height  # swinging arms and legs included
    x0, x1 = math.floor((foot[:, 0] - reach).min()), math.ceil((foot[:, 0] + reach).max())
    y0, y1 = math.floor(top), math.ceil(bottom)
    return _Board(float(bottom), x0, y0, _board_look(rng, (y1 - y0, x1 - x0)))


def _board_look(rng: np.random.Generator, shape: tuple[int, int]) -> np.ndarray:
    """A dark frame around a poster: a pale ground with a few coloured blocks, slightly grainy."""
    h, w = shape
    look = np.empty((h, w, 3), np.float32)
    look[:] = (58, 60, 64)
    rim = max(2, round(0.04 * min(h, w)))
    poster = look[rim : h - rim, rim : w - rim]
    poster[:] = rng.uniform(170, 235, 3)
    ph, pw = poster.shape[:2]
    for _ in range(3):
        bh, bw = round(rng.uniform(0.15, 0.4) * ph), round(rng.uniform(0.3, 0.8) * pw)
        by, bx = int(rng.integers(0, max(1, ph - bh))), int(rng.integers(0, max(1, pw - bw)))
        poster[by : by + bh, bx : bx + bw] = rng.uniform(30, 220, 3)
    return look * (1.0 + 0.03 * smooth_noise(rng, (h, w), 1.0)[:, :, None])


def _boards(
    rng: np.random.Generator, config: StreetConfig, ground: _Ground, people: list[_Person]
) -> list[_Drawable]:
    """One board for each of the first ``config.occluders`` people walking alone."""
    walkers = [p for p in people if p.info.kind == "walker"][: config.occluders]
    boards = [_make_board(rng, ground, p, config) for p in walkers]
    return [b for b in boards if b is not None]


def _distractors(
    rng: np.random.Generator, config: StreetConfig, ground: _Ground
) -> list[_Drawable]:
    n, fps = config.num_frames, config.fps
    items: list[_Drawable] = [_make_tape(rng, ground, n, fps) for _ in range(config.flutter)]
    items += [_make_foliage(rng, ground, n) for _ in range(config.foliage)]
    items += [_make_flicker(rng, ground, n) for _ in range(config.flicker)]
    items += [_make_car(rng, ground, n, fps) for _ in range(config.cars)]
    return items


# --- background ----------------------------------------------------------------------------------


def median_background(video_path: str | Path, max_frames: int = 200) -> np.ndarray:
    """Per-pixel median (BGR uint8) of up to ``max_frames`` frames sampled evenly from a video:
    the scene without the things that move through it."""
    if max_frames < 1:
        raise ValueError(f"max_frames must be >= 1, got {max_frames}")
    capture = cv2.VideoCapture(str(video_path))
    if not capture.isOpened():
        raise ValueError(f"{video_path}: cannot open the video")
    count = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
    wanted = (
        set(np.linspace(0, count - 1, min(count, max_frames)).round().astype(int).tolist())
        if count > 0
        else None
    )
    frames: list[np.ndarray] = []
    index = 0
    while capture.grab():
        if wanted is None or index in wanted:
            ok, frame = capture.retrieve()
            if ok:
                frames.append(frame)
        index += 1
    capture.release()
    if not frames:
        raise ValueError(f"{video_path}: no readable frames")
    if wanted is None and len(frames) > max_frames:
        picks = np.linspace(0, len(frames) - 1, max_frames).round().astype(int)
        frames = [frames[i] for i in picks]
    stack = np.stack(frames)
    out = np.empty(stack.shape[1:], np.uint8)
    for r in range(0, stack.shape[1], 32):  # in bands: np.median copies its input
        out[r : r + 32] = np.rint(np.median(stack[:, r : r + 32], axis=0)).astype(np.uint8)
    return out


@dataclass(frozen=True)
class _Canvas:
    """A supersampled drawing surface for the procedural background, in world px."""

    image: np.ndarray  # (H * ss, W * ss, 3) float32
    ss: int
    margin: int

    def rows(self) -> np.ndarray:
        return (np.arange(self.image.shape[0]) + 0.5) / self.ss - self.margin

    def cols(self) -> np.ndarray:
        return (np.arange(self.image.shape[1]) + 0.5) / self.ss - self.margin

    def point(self, x: float, y: float) -> tuple[int, int]:
        return (round((x + self.margin) * self.ss * ONE), round((y + self.margin) * self.ss * ONE))


_PAVING = _palette("150 155 160, 138 150 162, 120 122 128, 160 165 168")
_WALLS = _palette("70 90 150, 150 170 185, 140 140 142, 95 120 160")


def _pavement(rng: np.random.Generator, x_m: np.ndarray, z_m: np.ndarray) -> np.ndarray:
    """Tiled paving (running bond) with grout and per-tile shades, float32 (h, w, 3)."""
    tile = rng.uniform(0.4, 0.7)
    grey = float(rng.normal(0, 6))  # the same for all channels: no colour cast
    base = _PAVING[int(rng.integers(len(_PAVING)))] + grey + rng.normal(0, 1.5, 3)
    iz = np.floor(z_m / tile)
    xs = x_m / tile + 0.5 * (iz % 2)
    ix = np.floor(xs)
    shades = rng.normal(0, 1, (64, 64)).astype(np.float32)
    value = shades[ix.astype(int) % 64, iz.astype(int) % 64]
    gx = np.minimum(xs - ix, 1 - (xs - ix)) * tile
    gz = np.minimum(z_m / tile - iz, 1 - (z_m / tile - iz)) * tile
    grout = (gx < 0.012) | (gz < 0.012)
    out: np.ndarray = base * (1.0 + 0.05 * value)[..., None]
    out[grout] *= 0.72
    return out


def _road(
    rng: np.random.Generator, x_m: np.ndarray, z_m: np.ndarray, z0: float, width: float
) -> tuple[np.ndarray, np.ndarray]:
    """Asphalt band between depths z0 and z0 + width with kerbs and a dashed centre line."""
    asphalt = np.array([82, 84, 88], np.float32) + rng.normal(0, 4, 3).astype(np.float32)
    inside = (z_m >= z0) & (z_m <= z0 + width)
    colour = np.broadcast_to(asphalt, (*z_m.shape, 3)).copy()
    kerb = inside & ((z_m - z0 < 0.15) | (z0 + width - z_m < 0.15))
    colour[kerb] = (170, 172, 175)
    dash = inside & (np.abs(z_m - (z0 + width / 2)) < 0.06) & ((x_m % 4.0) < 2.0)
    colour[dash] = (215, 218, 220)
    return colour, inside


def _draw_ground(
    rng: np.random.Generator, canvas: _Canvas, ground: _Ground, base_row: float
) -> None:
    rows, cols = canvas.rows(), canvas.cols()
    below = rows >= base_row
    v, u = np.meshgrid(rows[below], cols, indexing="ij")
    G = ground.to_ground(np.stack([u, v], axis=-1).astype(np.float64))
    x_m, z_m = G[..., 0], G[..., 1]
    colour = _pavement(rng, x_m, z_m)
    if rng.uniform() < 0.7:
        z_lo, z_hi = float(z_m.min()), float(z_m.max())
        z0 = rng.uniform(z_lo + 0.2 * (z_hi - z_lo), z_lo + 0.6 * (z_hi - z_lo))
        road, inside = _road(rng, x_m, z_m, z0, rng.uniform(4.5, 7.0))
        colour[inside] = road[inside]
    if rng.uniform() < 0.5:
        edge = float(np.quantile(x_m, rng.uniform(0.05, 0.2)))
        grass = (x_m < edge) if rng.uniform() < 0.5 else (x_m > -edge)
        green = np.array([55, 118, 78], np.float32) + rng.normal(0, 5, 3).astype(np.float32)
        colour[grass] = green
    stains = smooth_noise(rng, colour.shape[:2], 18.0 * canvas.ss)[..., None]
    fine = smooth_noise(rng, colour.shape[:2], 0.7, 3)
    canvas.image[below] = colour * (1.0 + 0.05 * stains) + 5.0 * fine


def _draw_facade(
    rng: np.random.Generator, canvas: _Canvas, ground: _Ground, base_row: float
) -> None:
    """A building front over the far edge of the ground: wall, windows, a door."""
    rows = canvas.rows()
    above = rows < base_row
    if not above.any():
        return
    wall = _WALLS[int(rng.integers(len(_WALLS)))]
    shape = (int(above.sum()), canvas.image.shape[1])
    canvas.image[above] = wall * (
        1.0
        + 0.06 * smooth_noise(rng, shape, 1.0, 3)
        + 0.04 * smooth_noise(rng, shape, 8.0)[..., None]
    )
    px = float(ground.person_height(base_row)) / STATURE_M  # px per metre on the wall
    _openings(rng, canvas, ground.width, base_row, px)
    plinth = tuple(0.6 * wall)
    _rect(
        canvas,
        -canvas.margin,
        base_row - 0.12 * px,
        ground.width + 2 * canvas.margin,
        0.12 * px,
        plinth,
    )


def _openings(
    rng: np.random.Generator, canvas: _Canvas, width: int, base_row: float, px: float
) -> None:
    """Rows of windows, one floor above the other, and a door at street level."""
    spacing, floor = rng.uniform(2.4, 3.2) * px, rng.uniform(3.0, 3.4) * px
    xs = np.arange(-canvas.margin + rng.uniform(0, spacing), width + canvas.margin, spacing)
    door = int(rng.integers(len(xs)))
    for level in range(12):
        bottom = base_row - 0.9 * px - level * floor
        if bottom < -canvas.margin:
            break
        for k, x in enumerate(xs):
            if level == 0 and k == door:
                _rect(canvas, x, base_row - 2.2 * px, 1.2 * px, 2.2 * px, (45, 50, 60))
            else:
                _window(canvas, x, bottom - 1.5 * px, 1.3 * px, 1.5 * px)


def _rect(canvas: _Canvas, x: float, y: float, w: float, h: float, colour: tuple) -> None:
    cv2.rectangle(
        canvas.image,
        canvas.point(x, y),
        canvas.point(x + w, y + h),
        tuple(float(c) for c in colour),
        -1,
        cv2.LINE_AA,
        SHIFT,
    )


def _window(canvas: _Canvas, x: float, y: float, w: float, h: float) -> None:
    _rect(canvas, x - 0.06 * w, y - 0.06 * h, 1.12 * w, 1.12 * h, (200, 200, 198))
    _rect(canvas, x, y, w, h, (95, 80, 62))
    _rect(canvas, x, y, w, 0.35 * h, (150, 130, 110))
    _rect(canvas, x + 0.47 * w, y, 0.06 * w, h, (190, 190, 188))


def _draw_objects(rng: np.random.Generator, canvas: _Canvas, ground: _Ground) -> None:
    """Lamp posts, a bench, a bin and bollards standing on the ground (static, background)."""
    kinds = (
        ["post"] * int(rng.integers(1, 3))
        + ["bench", "bin"]
        + ["bollard"] * int(rng.integers(2, 5))
    )
    spots = [(_ground_spot(rng, ground, 0.02, 0.9), kind) for kind in kinds]
    for foot, kind in sorted(spots, key=lambda s: float(s[0][1])):
        px = float(ground.person_height(foot[1])) / STATURE_M
        x, y = float(foot[0]), float(foot[1])
        if kind == "post":
            _rect(canvas, x - 0.06 * px, y - 4.5 * px, 0.12 * px, 4.5 * px, (85, 88, 92))
            _rect(canvas, x - 0.25 * px, y - 4.65 * px, 0.5 * px, 0.18 * px, (60, 62, 66))
        elif kind == "bench":
            colour = (40, 70, 105)
            for leg in (-0.7, 0.6):
                _rect(canvas, x + leg * px, y - 0.45 * px, 0.1 * px, 0.45 * px, (40, 40, 42))
            _rect(canvas, x - 0.8 * px, y - 0.5 * px, 1.6 * px, 0.1 * px, colour)
            _rect(canvas, x - 0.8 * px, y - 0.9 * px, 1.6 * px, 0.25 * px, colour)
        elif kind == "bin":
            _rect(canvas, x - 0.25 * px, y - 0.9 * px, 0.5 * px, 0.9 * px, (45, 75, 45))
            _rect(canvas, x - 0.27 * px, y - 0.95 * px, 0.54 * px, 0.08 * px, (35, 55, 35))
        else:
            _rect(canvas, x - 0.07 * px, y - 0.9 * px, 0.14 * px, 0.9 * px, (175, 178, 180))


def _procedural_background(rng: np.random.Generator, ground: _Ground, margin: int) -> np.ndarray:
    """A paved plaza seen from above: building at the top, tiles with perspective, street
    furniture; BGR uint8 of the world plus ``margin`` px on every side."""
    ss = 2
    He, We = ground.height + 2 * margin, ground.width + 2 * margin
    canvas = _Canvas(np.zeros((He * ss, We * ss, 3), np.float32), ss, margin)
    base_row = ground.horizon - rng.uniform(0.02, 0.05) * ground.height
    if ground.slope > 0:
        base_row = max(base_row, ground.vanishing + 0.5 * (ground.horizon - ground.vanishing))
    _draw_ground(rng, canvas, ground, base_row)
    _draw_facade(rng, canvas, ground, base_row)
    _draw_objects(rng, canvas, ground)
    image = cv2.resize(canvas.image, (We, He), interpolation=cv2.INTER_AREA)
    yy, xx = np.mgrid[0:He, 0:We].astype(np.float32)
    r2 = ((xx - We / 2) / We) ** 2 + ((yy - He / 2) / He) ** 2
    light = (1.0 - 0.35 * r2 + 0.06 * (xx / We - 0.5))[..., None]
    lit: np.ndarray = np.clip(np.rint(image * light), 0, 255).astype(np.uint8)
    return lit


# --- people over time ----------------------------------------------------------------------------


@dataclass(eq=False)
class _Person:
    """One person's look and, per frame, where it stands and how it walks (world px)."""

    object_id: int
    look: _Look | RealLook
    info: StreetPerson
    heading: np.ndarray  # (N,) rad on the ground
    phase: np.ndarray  # (N,) gait phase, cycles
    tilt: np.ndarray  # (N,)
    present: np.ndarray  # (N,) bool: on its path and near the image

    @property
    def depth(self) -> np.ndarray:
        return self.info.foot[:, 1]

    def view(self, n: int, dx: int, dy: int) -> _View:
        u, v = self.info.foot[n]
        heading = float(self.heading[n])
        return _View(
            float(u) + dx,
            float(v) + dy,
            float(self.info.height[n]),
            math.cos(heading),
            math.sin(heading),
            float(self.tilt[n]),
        )


def _background_near(background: np.ndarray, foot: np.ndarray, h: float, margin: int) -> np.ndarray:
    """The median background colour around a standing figure at ``foot`` (world px)."""
    H, W = background.shape[:2]
    x0 = int(np.clip(foot[0] - 0.3 * h + margin, 0, W - 1))
    x1 = int(np.clip(foot[0] + 0.3 * h + margin, x0 + 1, W))
    y0 = int(np.clip(foot[1] - h + margin, 0, H - 1))
    y1 = int(np.clip(foot[1] + margin, y0 + 1, H))
    median: np.ndarray = np.median(background[y0:y1, x0:x1].reshape(-1, 3), axis=0).astype(
        np.float32
    )
    return median


def _person(
    object_id: int,
    unit: tuple[int, _Unit],
    plan: _Plan,
    look_for: Callable[[np.ndarray, float], _Look | RealLook],
    config: StreetConfig,
    ground: _Ground,
) -> _Person:
    """Where one person is and how it walks in every frame; ``look_for(foot, height)`` dresses it
    (given where it is halfway through its time in view)."""
    index, kind = unit[0], unit[1].kind
    ground_pos, heading, walked = plan.walk(np.arange(config.num_frames) / config.fps)
    foot = ground.to_image(ground_pos)
    height = ground.person_height(foot[:, 1]) * plan.stature / STATURE_M
    with np.errstate(invalid="ignore"):
        boxes = ground.boxes(foot, plan.stature)
        present = ~np.isnan(foot[:, 0]) & ground.in_view(boxes, config.camera_jitter + 2.0)
    seen = np.flatnonzero(present)
    middle = int(seen[len(seen) // 2]) if len(seen) else 0
    look = look_for(foot[middle], float(np.nan_to_num(height[middle], nan=50.0)))
    info = StreetPerson(object_id, kind, index, plan.speed, plan.stature, ground_pos, foot, height)
    phase = look.phase + walked / look.cycle
    tilt = ground.tilt(np.nan_to_num(foot[:, 1], nan=ground.horizon))
    return _Person(object_id, look, info, heading, phase, tilt, present)


def _dress(
    rng: np.random.Generator,
    background: np.ndarray,
    margin: int,
    stature: float,
    foot: np.ndarray,
    h: float,
) -> _Look:
    return _random_look(rng, stature, _background_near(background, foot, h, margin))


def _people(
    units: list[_Unit],
    rng: np.random.Generator,
    config: StreetConfig,
    ground: _Ground,
    background: np.ndarray,
    cutouts: CutoutLibrary | None,
) -> list[_Person]:
    """Everybody, numbered 1, 2, ... in the order of ``units``: drawn figures, or real people of
    ``cutouts``' set ``config.people``."""
    people: list[_Person] = []
    chooser = None
    if config.people != "drawn":
        if cutouts is None:
            raise ValueError(f"a street scene of real people ({config.people}) needs cut-outs")
        chooser = LookChooser(rng, cutouts.of_set(config.people))
    for index, unit in enumerate(units):
        for plan in unit.plans:
            look_for: Callable[[np.ndarray, float], _Look | RealLook]
            if chooser is None:
                look_for = partial(_dress, rng, background, config.camera_jitter, plan.stature)
            else:
                look_for = partial(_real_look, chooser, plan.stature)
            people.append(_person(len(people) + 1, (index, unit), plan, look_for, config, ground))
    return people


def _real_look(chooser: LookChooser, stature: float, foot: np.ndarray, h: float) -> RealLook:
    return chooser.look(stature)


@dataclass(eq=False)
class _Drawn:
    """A person drawn in the current frame: its silhouette size and image rectangle."""

    object_id: int
    pixels: int
    rect: tuple[int, int, int, int]


@dataclass(eq=False)
class _PersonItem:
    """A person as one of the depth-sorted things drawn in frame ``n``."""

    person: _Person
    depth: float
    drawn: list[_Drawn]
    shadow: float

    def draw(self, canvas: np.ndarray, label: np.ndarray, n: int, dx: int, dy: int) -> None:
        view = self.person.view(n, dx, dy)
        if self.shadow > 0:
            _cast_shadow(canvas, view, self.shadow)
        look, phase = self.person.look, float(self.person.phase[n])
        alpha = None
        if isinstance(look, RealLook):
            colour, alpha, x0, y0 = real_sprite(
                look, phase, (view.u, view.v), view.h, view.cos >= 0
            )
            mask = alpha >= 0.5
        else:
            sprite = _figure(look, phase, view)
            colour, mask = _colour(look, sprite, view)
            x0, y0 = sprite.x0, sprite.y0
        rect = _composite(canvas, label, colour, mask, x0, y0, self.person.object_id, alpha)
        if rect is not None:
            self.drawn.append(_Drawn(self.person.object_id, int(mask.sum()), rect))


def _cast_shadow(canvas: np.ndarray, view: _View, strength: float) -> None:
    """Darken a soft ellipse on the ground at the feet (light from the upper left)."""
    h = view.h
    cx, cy = view.u + 0.12 * h, view.v + 0.005 * h
    ax, ay = 0.3 * h, max(1.0, 0.06 * h * view.tilt / 0.4)
    pad = 0.08 * h + 2
    H, W = canvas.shape[:2]
    x0, x1 = max(0, math.floor(cx - ax - pad)), min(W, math.ceil(cx + ax + pad))
    y0, y1 = max(0, math.floor(cy - ay - pad)), min(H, math.ceil(cy + ay + pad))
    if x1 <= x0 or y1 <= y0:
        return
    blob = np.zeros((y1 - y0, x1 - x0), np.float32)
    axes = (round(ax * ONE), round(ay * ONE))
    cv2.ellipse(blob, _pt(np.array([cx - x0, cy - y0])), axes, 0, 0, 360, 1.0, -1, LINE, SHIFT)
    blob = cv2.GaussianBlur(blob, (0, 0), max(0.5, 0.025 * h))
    dark = 1.0 - strength * blob[:, :, None]
    canvas[y0:y1, x0:x1] = np.rint(canvas[y0:y1, x0:x1] * dark).astype(np.uint8)


def _visible_boxes(
    n: int, drawn: list[_Drawn], label: np.ndarray, min_visibility: float
) -> list[GroundTruthBox]:
    """Tight boxes of each drawn person's visible pixels, with visibility and conf."""
    boxes = []
    for d in sorted(drawn, key=lambda d: d.object_id):
        x0, y0, x1, y1 = d.rect
        mine = label[y0:y1, x0:x1] == d.object_id
        count = int(mine.sum())
        if count == 0:
            continue
        rows, cols = np.flatnonzero(mine.any(axis=1)), np.flatnonzero(mine.any(axis=0))
        visibility = round(count / d.pixels, 4)
        boxes.append(
            GroundTruthBox(
                n,
                d.object_id,
                float(x0 + cols[0]),
                float(y0 + rows[0]),
                float(cols[-1] - cols[0] + 1),
                float(rows[-1] - rows[0] + 1),
                visibility,
                0 if visibility < min_visibility else 1,
            )
        )
    return boxes


# --- rendering -----------------------------------------------------------------------------------


def _render(
    canvas: np.ndarray,
    label: np.ndarray,
    n: int,
    offset: tuple[int, int],
    people: list[_Person],
    distractors: list[_Drawable],
    config: StreetConfig,
) -> list[GroundTruthBox]:
    """Draw frame n's distractors and people far to near on ``canvas`` and ``label``; returns
    the people's visible boxes."""
    drawn: list[_Drawn] = []
    items = [
        _PersonItem(p, float(p.depth[n]), drawn, config.shadow) for p in people if p.present[n]
    ]
    # stable sort: on a tie distractors go first, then people by id
    for item in sorted([*distractors, *items], key=lambda item: item.depth):
        item.draw(canvas, label, n, *offset)
    return _visible_boxes(n, drawn, label, config.min_visibility)


def generate_street(
    config: StreetConfig,
    background: np.ndarray | None = None,
    cutouts: CutoutLibrary | None = None,
) -> StreetScene:
    """Render the street scene ``config`` describes, over ``background`` (any BGR or grey image,
    resized to the scene size) or, without one, a procedural plaza made from the seed; real
    people (``config.people`` not "drawn") come from ``cutouts``. Deterministic: the same config,
    background and cut-outs give bit-identical frames."""
    streams = [np.random.default_rng(s) for s in np.random.SeedSequence(config.seed).spawn(6)]
    layout_rng, look_rng, background_rng, distractor_rng, sensor_rng, jitter_rng = streams
    ground = _Ground.of(config)
    margin = config.camera_jitter
    world = (
        _procedural_background(background_rng, ground, margin)
        if background is None
        else fit_background(background, config.width, config.height, margin)
    )
    units = _layout(layout_rng, config, ground)
    people = _people(units, look_rng, config, ground, world, cutouts)
    distractors = _distractors(distractor_rng, config, ground)
    distractors += _boards(distractor_rng, config, ground, people)
    N, H, W = config.num_frames, config.height, config.width
    jitter = (
        jitter_rng.integers(-margin, margin + 1, size=(N, 2))
        if margin
        else np.zeros((N, 2), np.int64)
    )
    light_phases = sensor_rng.uniform(0, 2 * math.pi, size=2)
    frames = np.empty((N, H, W, 3), np.uint8)
    labels = np.zeros((N, H, W), np.uint16)
    boxes: list[list[GroundTruthBox]] = []
    for n in range(N):
        dx, dy = int(jitter[n, 0]), int(jitter[n, 1])
        canvas = world[margin - dy : margin - dy + H, margin - dx : margin - dx + W].copy()
        boxes.append(_render(canvas, labels[n], n, (dx, dy), people, distractors, config))
        frames[n] = sensor_effects(
            canvas, illumination_gain(config, n, light_phases), sensor_rng, config
        )
    scene = StreetScene(frames, float(config.fps), labels, boxes, jitter.astype(np.int64), config)
    scene.people = [p.info for p in people]
    return scene
