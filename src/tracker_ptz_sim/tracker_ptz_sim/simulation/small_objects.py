"""Small-object scenes: many small movers seen by a static camera, with ground truth (no rclpy).

The kind of clip seed 004 (GM-PHD tracking of many small objects with occlusion) is scored on: a
fixed camera over the ground (a real background, e.g. the median of a clip from
:func:`~tracker_ptz_sim.simulation.street.median_background`, or a generated one: soil, sand, moss
or concrete with pebbles and cracks) and on it ``num_objects`` small movers (by default 40 over the
clip, 25-35 in view at a time) shaped like flies, bees, ants, beetles and birds, mostly darker
than the ground or of a contrasting colour, some close to the ground's colour (``low_contrast``).
A mover's size is the longer side of its box in full view: it stays within ``object_size_range``
(10-30 px) at every heading. Static occluders (a leaf, a post, a branch) are part of the
background and hide whatever passes behind them.

Time is in frames: the clip is ``num_frames`` frames at ``fps`` = 25 (a 40 ms frame, T = 1 frame in
the seed's models), speeds are px/frame and turns rad/frame. Every mover moves at a nearly
constant velocity: its heading drifts with a smoothly varying turn rate (spread ``turn_sigma``)
and its speed by a few per cent, so a constant-velocity model is right most of the time. Half of
the free movers stay in view (they turn back smoothly before a border), the others leave through a
border when they reach it; a ``late_fraction`` of them are born after the first frame, half
entering through a border, half appearing inside the view. ``crossings`` pairs of movers pass the
same point in the same frame (one hides the other), and one mover per occluder (the first ones, as
long as movers are left) crosses it the narrow way at a speed from the faster half of
``speed_range``, hidden completely for a few frames in the middle of the clip. Movers overlap one
another freely: each has a depth and the nearer one is drawn later. A mover that has left is gone
for good; one born too late to come into view never appears.

Ground truth follows :mod:`~tracker_ptz_sim.simulation.scenes` (image px, the origin at the
top-left corner of the top-left pixel): ``labels`` (uint16) give per pixel the id of the mover
visible there (occluders are background, 0); per frame every mover in the scene (any part of its
sprite inside the frame) has a box. A mover with visible pixels gets the tight box of those pixels
and its visibility, the share of its sprite's pixels visible (the rest hidden by occluders, nearer
movers or the frame border). A mover with no visible pixel (behind an occluder or a nearer mover)
keeps its full box, clipped to the frame, with visibility 0: where it is, for a tracker that
coasts. Boxes less visible than ``min_visibility``, the hidden ones included, get ``conf`` 0
(MOTChallenge's "ignore", as the street scenes' barely visible people: neither a miss nor a false
positive). Write and read the scenes with :func:`~tracker_ptz_sim.simulation.scene_files.write_scene` /
:func:`~tracker_ptz_sim.simulation.scene_files.load_scene` (``scene.json``'s generator is
"small_objects"). :func:`generate_small_objects` returns a :class:`SmallObjectsScene`, which also
carries every mover's path (:class:`SmallMover`), the crossings and the occluders' mask.

Every random choice comes from ``numpy.random`` streams spawned from the seed, one per concern
(background, occluders, movers, sensor), so the same config (and background) always gives
bit-identical frames. The camera effects (lens blur, lighting drift, sensor noise, JPEG) are the
street scenes' (:mod:`~tracker_ptz_sim.simulation.street`).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass, field
from typing import ClassVar

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
from tracker_ptz_sim.simulation.scenes import (
    GroundTruthBox,
    Scene,
    clip_problems,
    negative_counts,
)

MAX_OBJECTS = 200
MAX_OCCLUDERS = 8
HEADINGS = 36  # sprites are drawn at this many headings (every 10 degrees)
STAY_SHARE = 0.5  # of the free movers: turn back before a border (the others leave)
STEER_RATE = 0.12  # rad/frame, the sharpest turn of a mover turning back from a border
SPECIES = ("fly", "bee", "ant", "beetle", "bird")
SPECIES_WEIGHTS = (0.3, 0.15, 0.25, 0.15, 0.15)


@dataclass(frozen=True)
class SmallObjectsConfig:
    """Everything that defines a small-object scene; the same config always renders the same
    scene. Speeds and turns are per frame (see the module docstring)."""

    generator: ClassVar[str] = "small_objects"  # scene.json's "generator" for this kind of config

    width: int = 640  # px
    height: int = 480  # px
    num_frames: int = 200
    fps: float = 25.0
    num_objects: int = 40  # movers over the whole clip, ids 1..num_objects
    object_size_range: tuple[int, int] = (10, 30)  # px, longer side of a mover's box in full view
    speed_range: tuple[float, float] = (0.8, 3.0)  # px/frame
    turn_sigma: float = 0.015  # rad/frame, spread of each mover's slowly varying turn rate
    late_fraction: float = 0.3  # share of the free movers born after the first frame
    crossings: int = 5  # pairs of movers passing the same point in the same frame
    num_occluders: int = 3  # static opaque shapes (leaf, post, branch) in front of the movers
    low_contrast: float = 0.15  # share of movers coloured close to the ground they walk on
    optical_blur: float = 0.5  # px, Gaussian sigma of the lens blur of every rendered frame
    noise_sigma: float = 3.0  # grey levels, Gaussian sensor noise, new every frame
    jpeg_quality: int = 80  # every frame goes through JPEG at this quality; 0 = no compression
    illumination_drift: float = 0.05  # relative amplitude of a slow sinusoidal gain
    illumination_period: float = 20.0  # s
    min_visibility: float = 0.25  # boxes less visible than this get conf 0 (ignored)
    seed: int = 0

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        """Why this scene cannot be rendered (empty: it can)."""
        problems = clip_problems(self, min_side=64)
        problems += negative_counts(self, ("crossings", "num_occluders"))
        problems += _count_problems(self)
        problems += _size_problems(self)
        problems += _motion_problems(self)
        problems += _camera_problems(self)
        return problems


def _count_problems(c: SmallObjectsConfig) -> list[str]:
    """`SmallObjectsConfig.problems` of the numbers of movers, crossings and occluders."""
    problems: list[str] = []
    if not 1 <= c.num_objects <= MAX_OBJECTS:
        problems.append(f"num_objects must be in [1, {MAX_OBJECTS}], got {c.num_objects}")
    if 2 * c.crossings > c.num_objects:
        problems.append(
            f"crossings need two movers each: 2 * crossings ({2 * c.crossings}) must be <= "
            f"num_objects ({c.num_objects})"
        )
    if c.num_occluders > MAX_OCCLUDERS:
        problems.append(f"num_occluders must be <= {MAX_OCCLUDERS}, got {c.num_occluders}")
    return problems


def _size_problems(c: SmallObjectsConfig) -> list[str]:
    """`SmallObjectsConfig.problems` of the movers' sizes."""
    problems: list[str] = []
    lo, hi = c.object_size_range
    top = min(c.width, c.height) // 4
    if not 6 <= lo <= hi <= top:
        problems.append(
            f"object_size_range must satisfy 6 <= min <= max <= {top} (a quarter of the "
            f"shorter side), got {c.object_size_range}"
        )
    elif hi < 1.5 * lo:
        problems.append(
            "object_size_range must satisfy max >= 1.5 * min (a mover's box changes with its "
            f"heading by up to that much), got {c.object_size_range}"
        )
    return problems


def _motion_problems(c: SmallObjectsConfig) -> list[str]:
    """`SmallObjectsConfig.problems` of the movers' speeds and turns, and of the shares (late
    births, low contrast, the visibility that counts)."""
    problems: list[str] = []
    lo_v, hi_v = c.speed_range
    if not (math.isfinite(lo_v) and math.isfinite(hi_v) and 0 <= lo_v <= hi_v <= 20):
        problems.append(
            f"speed_range must satisfy 0 <= min <= max <= 20 px/frame, got {c.speed_range}"
        )
    if not (math.isfinite(c.turn_sigma) and 0 <= c.turn_sigma <= 0.5):
        problems.append(f"turn_sigma must be in [0, 0.5] rad/frame, got {c.turn_sigma}")
    for name in ("late_fraction", "low_contrast", "min_visibility"):
        value = getattr(c, name)
        if not 0 <= value <= 1:
            problems.append(f"{name} must be in [0, 1], got {value}")
    return problems


def _camera_problems(c: SmallObjectsConfig) -> list[str]:
    """`SmallObjectsConfig.problems` of the camera effects (blur, noise, lighting, JPEG)."""
    problems: list[str] = []
    for name in ("optical_blur", "noise_sigma", "illumination_period"):
        value = getattr(c, name)
        if not (math.isfinite(value) and value >= 0):
            problems.append(f"{name} must be a finite number >= 0, got {value}")
    if not 0 <= c.illumination_drift < 1.0:
        problems.append(f"illumination_drift must be in [0, 1), got {c.illumination_drift}")
    if not 0 <= c.jpeg_quality <= 100:
        problems.append(f"jpeg_quality must be in [0, 100], got {c.jpeg_quality}")
    return problems


@dataclass(frozen=True, eq=False)
class SmallMover:
    """One mover's path through the scene (image px; NaN where it is not in the scene)."""

    object_id: int
    species: str  # "fly", "bee", "ant", "beetle" or "bird"
    role: str  # "free", "crossing" or "occluded" (sent behind an occluder)
    partner: int  # the other mover of a crossing pair, 0 for none
    length: float  # px, the sprite's length (a bird's wingspan)
    depth: int  # drawing order: a larger depth is nearer, drawn later
    centre: np.ndarray  # (N, 2) px, the sprite's centre (drawn at the nearest whole pixel)
    heading: np.ndarray  # (N,) rad, direction of motion in the image (0 = +x, pi/2 = +y, down)

    @property
    def present(self) -> np.ndarray:
        present: np.ndarray = ~np.isnan(self.centre[:, 0])
        return present


@dataclass
class SmallObjectsScene(Scene):
    """A rendered small-object scene: a :class:`Scene` plus the movers' paths, the crossings
    (id, id, frame where both centres are at the same point) and the occluders' mask."""

    movers: list[SmallMover] = field(default_factory=list)
    crossings: list[tuple[int, int, int]] = field(default_factory=list)
    occluder_mask: np.ndarray = field(default_factory=lambda: np.zeros((0, 0), bool))


# --- sprites -----------------------------------------------------------------------------------

# part ids of a sprite's part image (0 = not the mover)
BODY, HEAD, WING, ACCENT, SPOT = 1, 2, 3, 4, 5

# Shapes in body units (x forward, y to the side, the sprite spans about 1): ellipses
# (cx, cy, half length, half width, angle in degrees, part) and polygons ((x, y), ..., part), drawn
# in order (later on top).
Ellipse = tuple[float, float, float, float, float, int]
Polygon = tuple[tuple[tuple[float, float], ...], int]


def _wings(x: float, y: float, a: float, b: float, sweep: float) -> list[Ellipse]:
    return [(x, y, a, b, sweep, WING), (x, -y, a, b, -sweep, WING)]


SHAPES: dict[str, tuple[list[Ellipse], list[Polygon]]] = {
    "fly": (
        [
            *_wings(-0.14, 0.17, 0.3, 0.11, 28.0),
            (-0.05, 0.0, 0.36, 0.15, 0.0, BODY),
            (0.34, 0.0, 0.13, 0.15, 0.0, HEAD),
        ],
        [],
    ),
    "bee": (
        [
            *_wings(-0.06, 0.2, 0.26, 0.1, 32.0),
            (-0.18, 0.0, 0.31, 0.19, 0.0, ACCENT),
            (0.16, 0.0, 0.15, 0.14, 0.0, BODY),
            (0.37, 0.0, 0.1, 0.12, 0.0, HEAD),
        ],
        [],
    ),
    "ant": (
        [
            (-0.27, 0.0, 0.22, 0.15, 0.0, BODY),
            (0.03, 0.0, 0.14, 0.08, 0.0, BODY),
            (0.32, 0.0, 0.13, 0.12, 0.0, HEAD),
        ],
        [],
    ),
    "beetle": (
        [
            (-0.06, 0.0, 0.42, 0.33, 0.0, ACCENT),
            (0.38, 0.0, 0.1, 0.17, 0.0, HEAD),
            (-0.15, 0.14, 0.08, 0.07, 0.0, SPOT),
            (-0.15, -0.14, 0.08, 0.07, 0.0, SPOT),
            (0.12, 0.12, 0.07, 0.06, 0.0, SPOT),
            (0.12, -0.12, 0.07, 0.06, 0.0, SPOT),
        ],
        [],
    ),
    "bird": (  # seen from above, gliding: the wingspan is its length
        [(-0.02, 0.0, 0.2, 0.07, 0.0, BODY), (0.2, 0.0, 0.06, 0.055, 0.0, HEAD)],
        [
            (
                (
                    (0.09, 0.04),
                    (0.06, 0.22),
                    (-0.06, 0.5),
                    (-0.1, 0.42),
                    (-0.06, 0.2),
                    (-0.1, 0.04),
                ),
                WING,
            ),
            (
                (
                    (0.09, -0.04),
                    (0.06, -0.22),
                    (-0.06, -0.5),
                    (-0.1, -0.42),
                    (-0.06, -0.2),
                    (-0.1, -0.04),
                ),
                WING,
            ),
            (((-0.16, 0.03), (-0.3, 0.08), (-0.32, 0.0), (-0.3, -0.08), (-0.16, -0.03)), BODY),
        ],
    ),
}


@dataclass(frozen=True, eq=False)
class _Sprite:
    """A mover drawn at one heading, cropped to its pixels."""

    mask: np.ndarray  # (h, w) bool
    colour: np.ndarray  # (h, w, 3) uint8
    x0: int  # top-left corner relative to the (rounded) centre, px
    y0: int
    pixels: int


@dataclass(frozen=True, eq=False)
class _Look:
    lut: np.ndarray  # (6, 3) float32 BGR colour of each part id
    stripes: bool  # ACCENT in bands across the body (a bee's abdomen)
    texture: np.ndarray  # (8, 8) float32 in [-1, 1], upsampled over the sprite


def _part_image(species: str, length: float, heading: float) -> tuple[np.ndarray, float]:
    """The part image of a mover of ``length`` px at ``heading`` and its centre (px)."""
    side = math.ceil(1.2 * length) + 5
    centre = side / 2
    parts = np.zeros((side, side), np.uint8)
    cos, sin = math.cos(heading), math.sin(heading)

    def point(x: float, y: float) -> tuple[int, int]:
        u, v = centre + length * (x * cos - y * sin), centre + length * (x * sin + y * cos)
        return round(u * ONE), round(v * ONE)

    ellipses, polygons = SHAPES[species]
    degrees = math.degrees(heading)
    for poly, part in polygons:  # under the body and head
        points = np.array([point(x, y) for x, y in poly], np.int32)
        cv2.fillPoly(parts, [points], part, LINE, SHIFT)
    for x, y, a, b, angle, part in ellipses:
        axes = (max(1, round(a * length * ONE)), max(1, round(b * length * ONE)))
        cv2.ellipse(parts, point(x, y), axes, degrees + angle, 0, 360, part, -1, LINE, SHIFT)
    return parts, centre


def _sprite(species: str, look: _Look, length: float, heading: float) -> _Sprite:
    parts, centre = _part_image(species, length, heading)
    mask = parts > 0
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    r0, r1, c0, c1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
    parts, mask = parts[r0:r1, c0:c1], mask[r0:r1, c0:c1]
    h, w = parts.shape
    colour = look.lut[parts]
    # body coordinates of every pixel (units of length): stripes, the highlight
    yy, xx = np.mgrid[r0:r1, c0:c1].astype(np.float32) + 0.5 - centre
    forward = (xx * math.cos(heading) + yy * math.sin(heading)) / length
    side = (-xx * math.sin(heading) + yy * math.cos(heading)) / length
    if look.stripes:
        bands = (np.floor(forward / 0.09).astype(int) % 2 == 0) & (parts == ACCENT)
        colour[bands] = look.lut[SPOT]
    texture = cv2.resize(look.texture, (w, h), interpolation=cv2.INTER_LINEAR)
    shine = np.exp(-((forward - 0.05) ** 2 + (side + 0.08) ** 2) / 0.02)
    solid = (parts != WING)[:, :, None]
    colour = colour * (1.0 + 0.07 * texture[:, :, None]) + 28.0 * shine[:, :, None] * solid
    colour = np.clip(np.rint(colour), 0, 255).astype(np.uint8)
    x0, y0 = c0 - round(centre), r0 - round(centre)
    return _Sprite(mask, colour, x0, y0, int(mask.sum()))


def _bank(species: str, look: _Look, length: float) -> list[_Sprite]:
    return [_sprite(species, look, length, 2 * math.pi * k / HEADINGS) for k in range(HEADINGS)]


def _box_sides(bank: list[_Sprite]) -> tuple[int, int]:
    """The smallest and largest longer side of the sprites' boxes over all headings."""
    sides = [max(s.mask.shape) for s in bank]
    return min(sides), max(sides)


def _sized_bank(
    species: str, look: _Look, target: float, size_range: tuple[int, int]
) -> tuple[list[_Sprite], float]:
    """Sprites whose box's longer side is at most ``target`` px at any heading and within
    ``size_range`` at every heading (as far as the shape allows), and their length."""
    lo, hi = size_range
    length = float(target)
    bank = _bank(species, look, length)
    for _ in range(8):
        small, large = _box_sides(bank)
        if large > min(target, hi):
            length *= (min(target, hi) - 0.5) / large
        elif small < lo:
            length *= (lo + 0.5) / small
        else:
            break
        bank = _bank(species, look, length)
    return bank, length


_FLAT = np.zeros((8, 8), np.float32)


@functools.cache
def _spread(species: str) -> float:
    """How much a species' box's longer side changes with the heading (largest / smallest)."""
    small, large = _box_sides(_bank(species, _Look(np.zeros((6, 3), np.float32), False, _FLAT), 60))
    return large / small


def _shade(colour: np.ndarray, rng: np.random.Generator, spread: float = 10.0) -> np.ndarray:
    return np.clip(colour + rng.normal(0, spread, 3), 6, 250).astype(np.float32)


def _random_look(rng: np.random.Generator, species: str, ground: np.ndarray, faint: bool) -> _Look:
    """Colours of each part: dark or contrasting, or (``faint``) close to the ``ground`` colour."""
    lut = np.zeros((6, 3), np.float32)
    dark = _shade(np.array([35, 38, 42], np.float32) * rng.uniform(0.6, 1.6), rng, 6)
    lut[BODY], lut[HEAD] = dark, dark * rng.uniform(0.7, 1.1)
    lut[SPOT] = dark * 0.6
    lut[WING] = np.clip(0.5 * ground + 0.5 * rng.uniform(175, 215), 0, 255)  # translucent grey
    if species == "bee":
        lut[ACCENT] = _shade(np.array([40, 165, 215], np.float32), rng)
        lut[SPOT] = dark
    elif species == "beetle":
        palette = np.array([[35, 40, 190], [30, 120, 225], [40, 110, 40], [30, 30, 30]], np.float32)
        lut[ACCENT] = _shade(palette[int(rng.integers(len(palette)))], rng)
    elif species == "ant" and rng.uniform() < 0.4:
        lut[BODY] = _shade(np.array([35, 55, 120], np.float32), rng)  # a red ant
    elif species == "bird":
        lut[BODY] = _shade(np.array([45, 55, 65], np.float32) * rng.uniform(0.6, 1.5), rng, 3)
        lut[HEAD] = lut[BODY] * 0.8
        lut[WING] = lut[BODY] * rng.uniform(0.75, 1.2)
    if faint:  # a little darker or lighter than the ground, parts alike
        offset = rng.choice([-1.0, 1.0]) * rng.uniform(14, 26)
        for part in (BODY, HEAD, ACCENT, SPOT, WING):
            lut[part] = np.clip(ground + offset + rng.normal(0, 5, 3), 0, 255)
        lut[SPOT] = np.clip(lut[SPOT] - 8, 0, 255)
    texture = rng.uniform(-1, 1, size=(8, 8)).astype(np.float32)
    return _Look(lut, species == "bee" and not faint, texture)


# --- background and occluders ------------------------------------------------------------------

_GROUNDS = np.array(
    [[70, 100, 135], [125, 165, 195], [75, 125, 105], [150, 152, 155], [60, 90, 115]], np.float32
)  # BGR: soil, sand, moss, concrete, leaf litter


def _generated_ground(rng: np.random.Generator, width: int, height: int) -> np.ndarray:
    """Ground seen from above: a base colour with patches and grain, pebbles and cracks
    (BGR uint8)."""
    shape = (height, width)
    base = _GROUNDS[int(rng.integers(len(_GROUNDS)))] + rng.normal(0, 6, 3).astype(np.float32)
    patches = smooth_noise(rng, shape, 0.06 * min(shape))[:, :, None]
    mottle = smooth_noise(rng, shape, 4.0)[:, :, None]
    grain = smooth_noise(rng, shape, 0.7, 3)
    image = base * (1.0 + 0.1 * patches + 0.06 * mottle) + 6.0 * grain
    canvas = np.clip(image, 0, 255).astype(np.uint8)
    for _ in range(int(rng.integers(3, 8))):  # cracks: dark random walks
        point = rng.uniform((0, 0), (width, height))
        angle = rng.uniform(0, 2 * math.pi)
        points = [point]
        for _ in range(int(rng.integers(6, 20))):
            angle += rng.normal(0, 0.5)
            point = point + rng.uniform(6, 16) * np.array([math.cos(angle), math.sin(angle)])
            points.append(point)
        line = np.round(np.array(points) * ONE).astype(np.int32)
        colour = tuple(float(c) for c in 0.6 * base)
        cv2.polylines(canvas, [line], False, colour, 1, cv2.LINE_AA, SHIFT)
    pebbles = int(width * height / 3500)
    for _ in range(pebbles):  # static clutter of the movers' size, most of it paler
        centre = rng.uniform((0, 0), (width, height))
        axes = rng.uniform(1.5, 7.0) * np.array([1.0, rng.uniform(0.5, 1.0)])
        tone = rng.uniform(0.8, 1.35) if rng.uniform() < 0.8 else rng.uniform(0.5, 0.8)
        colour = tuple(float(c) for c in np.clip(base * tone + rng.normal(0, 8, 3), 0, 255))
        cv2.ellipse(
            canvas,
            (round(centre[0] * ONE), round(centre[1] * ONE)),
            (max(1, round(axes[0] * ONE)), max(1, round(axes[1] * ONE))),
            float(rng.uniform(0, 180)),
            0,
            360,
            colour,
            -1,
            cv2.LINE_AA,
            SHIFT,
        )
    yy, xx = np.mgrid[0:height, 0:width].astype(np.float32)
    r2 = ((xx - width / 2) / width) ** 2 + ((yy - height / 2) / height) ** 2
    light = (1.0 - 0.3 * r2)[:, :, None]
    lit: np.ndarray = np.clip(np.rint(canvas * light), 0, 255).astype(np.uint8)
    return lit


@dataclass(frozen=True, eq=False)
class _Occluder:
    kind: str  # "leaf", "post" or "branch"
    mask: np.ndarray  # (H, W) bool
    colour: np.ndarray  # (H, W, 3) float32, valid under the mask


def _inside_depth(mask: np.ndarray) -> np.ndarray:
    """Distance (px) of every mask pixel to the nearest pixel outside it or the frame."""
    padded = cv2.copyMakeBorder(mask.astype(np.uint8), 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0)
    return cv2.distanceTransform(padded, cv2.DIST_L2, 5)[1:-1, 1:-1]


def _leaf(rng: np.random.Generator, width: int, height: int, size: int) -> _Occluder:
    """A leaf lying on the ground: pointed at both ends, a lighter midrib and veins."""
    length = _extent(rng.uniform(3.5, 5.0) * size, 2.5 * size, 0.35 * min(width, height))
    breadth = rng.uniform(0.42, 0.55) * length
    centre = rng.uniform((0.15 * width, 0.15 * height), (0.85 * width, 0.85 * height))
    angle = rng.uniform(0, math.pi)
    s = np.linspace(-0.5, 0.5, 41)
    half = 0.5 * breadth * np.sin(math.pi * (s + 0.5)) ** 0.8
    bend = 0.08 * length * rng.uniform(-1, 1) * (1 - (2 * s) ** 2)
    outline = np.concatenate(
        [np.stack([s * length, bend + half], 1), np.stack([s * length, bend - half], 1)[::-1]]
    )
    rot = np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])
    points = outline @ rot.T + centre
    mask = np.zeros((height, width), np.uint8)
    cv2.fillPoly(mask, [np.round(points * ONE).astype(np.int32)], 1, LINE, SHIFT)
    green = np.array([rng.uniform(35, 70), rng.uniform(105, 150), rng.uniform(55, 100)])
    yy, xx = np.mgrid[0:height, 0:width].astype(np.float32)
    along = (xx - centre[0]) * math.cos(angle) + (yy - centre[1]) * math.sin(angle)
    across = -(xx - centre[0]) * math.sin(angle) + (yy - centre[1]) * math.cos(angle)
    across = across - np.interp(along / length, s, bend)
    veins = np.abs(((along - 0.9 * np.abs(across)) / (0.09 * length)) % 1.0 - 0.5) < 0.06
    rib = np.abs(across) < max(1.0, 0.02 * length)
    shade = 1.0 + 0.08 * smooth_noise(rng, (height, width), 2.0) + 0.12 * (along / length)
    colour = green * shade[:, :, None]
    colour[veins] *= 1.12
    colour[rib] = 1.35 * green
    return _Occluder("leaf", mask > 0, colour.astype(np.float32))


def _post(rng: np.random.Generator, width: int, height: int, size: int) -> _Occluder:
    """A round post or stake reaching in from a border (wood or metal), shaded as a cylinder."""
    thick = _extent(rng.uniform(1.6, 2.2) * size, 1.4 * size, 0.15 * min(width, height))
    tilt = rng.uniform(-0.12, 0.12)
    sign = 1.0 if rng.uniform() < 0.5 else -1.0  # from the top (left) or the bottom (right)
    if rng.uniform() < 0.6:  # upright
        x = rng.uniform(0.2, 0.8) * width
        start, direction, span = (
            np.array([x, -2.0 if sign > 0 else height + 2.0]),
            (tilt, sign),
            height,
        )
    else:
        y = rng.uniform(0.2, 0.8) * height
        start, direction, span = (
            np.array([-2.0 if sign > 0 else width + 2.0, y]),
            (sign, tilt),
            width,
        )
    axis = np.array(direction) / math.hypot(*direction)
    reach = (
        (span + 4)
        / max(abs(axis).max(), 1e-9)
        * (1.0 if rng.uniform() < 0.5 else rng.uniform(0.5, 0.85))
    )
    end = start + reach * axis
    normal = np.array([-axis[1], axis[0]])
    corners = np.array(
        [
            start + normal * thick / 2,
            end + normal * thick / 2,
            end - normal * thick / 2,
            start - normal * thick / 2,
        ]
    )
    mask = np.zeros((height, width), np.uint8)
    cv2.fillConvexPoly(mask, np.round(corners * ONE).astype(np.int32), 1, LINE, SHIFT)
    yy, xx = np.mgrid[0:height, 0:width].astype(np.float32)
    u = ((xx - start[0]) * normal[0] + (yy - start[1]) * normal[1]) / (thick / 2)
    wood = rng.uniform() < 0.6
    base = (
        np.array([rng.uniform(50, 80), rng.uniform(85, 115), rng.uniform(120, 150)])
        if wood
        else np.full(3, rng.uniform(110, 150))
    )
    cylinder = 1.1 - 0.45 * np.clip(u - 0.3, -1.3, 1.0) ** 2
    grain = smooth_noise(rng, (height, width), 1.2) * (0.1 if wood else 0.03)
    colour = base * (cylinder + grain)[:, :, None]
    return _Occluder("post", mask > 0, colour.astype(np.float32))


def _branch(rng: np.random.Generator, width: int, height: int, size: int) -> _Occluder:
    """A branch reaching in from a border: a curve that thins towards its tip, with a twig."""
    side = int(rng.integers(4))
    along = rng.uniform(0.2, 0.8)
    start = {
        0: (-3.0, along * height),
        1: (width + 3.0, along * height),
        2: (along * width, -3.0),
        3: (along * width, height + 3.0),
    }[side]
    goal = rng.uniform((0.3 * width, 0.3 * height), (0.7 * width, 0.7 * height))
    mask = np.zeros((height, width), np.uint8)
    thick = _extent(rng.uniform(1.4, 1.8) * size, 1.3 * size, 0.15 * min(width, height))
    main = _curve(rng, np.array(start), goal)
    _stroke(mask, main, thick, 0.4 * thick)
    fork = main[int(rng.integers(len(main) // 3, 2 * len(main) // 3))]
    heading = math.atan2(*(goal - np.array(start))[::-1]) + rng.choice([-1, 1]) * 0.8
    tip = fork + rng.uniform(0.15, 0.3) * min(width, height) * np.array(
        [math.cos(heading), math.sin(heading)]
    )
    _stroke(mask, _curve(rng, fork, tip), 0.45 * thick, 0.2 * thick)
    bark = np.array([rng.uniform(35, 55), rng.uniform(55, 75), rng.uniform(75, 100)])
    depth = _inside_depth(mask > 0)
    round_ = np.clip(depth / max(0.25 * thick, 1.0), 0, 1) ** 0.5
    streaks = smooth_noise(rng, (height, width), 1.0) * 0.12
    colour = bark * (0.65 + 0.45 * round_ + streaks)[:, :, None]
    return _Occluder("branch", mask > 0, colour.astype(np.float32))


def _curve(rng: np.random.Generator, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    chord = end - start
    normal = np.array([-chord[1], chord[0]]) / max(float(np.hypot(*chord)), 1e-9)
    bend = rng.uniform(-0.2, 0.2) * float(np.hypot(*chord))
    t = np.linspace(0, 1, 60)[:, None]
    middle = start + chord / 2 + bend * normal
    curve: np.ndarray = (1 - t) ** 2 * start + 2 * (1 - t) * t * middle + t**2 * end
    return curve


def _stroke(mask: np.ndarray, points: np.ndarray, thick: float, tip: float) -> None:
    widths = np.linspace(thick, tip, len(points))
    for (x, y), w in zip(points, widths, strict=True):
        cv2.circle(mask, (round(x * ONE), round(y * ONE)), round(w / 2 * ONE), 1, -1, LINE, SHIFT)


_OCCLUDER_MAKERS = {"leaf": _leaf, "post": _post, "branch": _branch}


def _extent(wanted: float, least: float, frame_share: float) -> float:
    """An occluder's size: ``wanted``, but no more than ``frame_share`` of a small frame unless
    that is less than ``least`` (what it takes to hide the largest mover)."""
    return min(wanted, max(least, frame_share))


def _occluders(rng: np.random.Generator, config: SmallObjectsConfig) -> list[_Occluder]:
    """A leaf, a post and a branch in a random order, then more of each in turn, each placed
    (in up to 10 tries) where it covers little of the others."""
    kinds = [str(k) for k in rng.permutation(list(_OCCLUDER_MAKERS))]
    size = config.object_size_range[1]
    union = np.zeros((config.height, config.width), bool)
    occluders = []
    for i in range(config.num_occluders):
        make = _OCCLUDER_MAKERS[kinds[i % len(kinds)]]
        for _ in range(10):
            occ = make(rng, config.width, config.height, size)
            if (occ.mask & union).sum() <= 0.02 * occ.mask.sum():
                break
        occluders.append(occ)
        union |= occ.mask
    return occluders


# --- paths -------------------------------------------------------------------------------------


def _smooth(rng: np.random.Generator, n: int, sigma: float) -> np.ndarray:
    """(n,) Gaussian noise smoothed over ~``sigma`` frames, unit spread."""
    half = math.ceil(3 * sigma)
    kernel = np.exp(-0.5 * (np.arange(-half, half + 1) / sigma) ** 2)
    kernel /= math.sqrt(float((kernel**2).sum()))
    return np.convolve(rng.standard_normal(n + 2 * half), kernel, mode="valid")


@dataclass(frozen=True, eq=False)
class _Motion:
    """What a mover's path is made of: per frame a turn (rad) and a speed (px/frame)."""

    turns: np.ndarray  # (N,)
    speeds: np.ndarray  # (N,)

    @classmethod
    def draw(cls, rng: np.random.Generator, config: SmallObjectsConfig) -> _Motion:
        n = config.num_frames
        speed = rng.uniform(*config.speed_range)
        turns = config.turn_sigma * _smooth(rng, n, 6.0)
        speeds = speed * (1.0 + 0.04 * np.clip(_smooth(rng, n, 10.0), -2.5, 2.5))  # +-10 %
        return cls(turns, np.maximum(speeds, 0.0))


def _anchored(motion: _Motion, anchor: int, point: np.ndarray, heading: float) -> np.ndarray:
    """Centres (N, 2) and headings (N,) of a path through ``point`` at frame ``anchor`` with
    ``heading`` there, as columns (x, y, heading)."""
    turns = motion.turns.copy()
    turns[anchor] = 0.0
    cum = np.cumsum(turns)
    headings = heading + cum - cum[anchor]
    steps = motion.speeds[:, None] * np.stack([np.cos(headings), np.sin(headings)], axis=1)
    travelled = np.concatenate([[[0.0, 0.0]], np.cumsum(steps, axis=0)[:-1]])
    centres = point + travelled - travelled[anchor]
    return np.column_stack([centres, headings])


def _steered(
    motion: _Motion, birth: int, point: np.ndarray, heading: float, config: SmallObjectsConfig
) -> np.ndarray:
    """Like :func:`_anchored` from ``birth`` on, turning back before the borders (frames before
    ``birth`` are NaN)."""
    W, H, n = config.width, config.height, config.num_frames
    margin = 0.08 * min(W, H) + config.object_size_range[1]
    out = np.full((n, 3), np.nan)
    pos, angle = point.astype(float), heading
    inside = bool(0 <= pos[0] < W and 0 <= pos[1] < H)  # an entering mover is let in first
    for k in range(birth, n):
        if k > birth:
            angle += float(motion.turns[k])
            x, y = pos
            inside = inside or (margin < x < W - margin and margin < y < H - margin)
            outward = (
                (x < margin and math.cos(angle) < 0)
                or (x > W - margin and math.cos(angle) > 0)
                or (y < margin and math.sin(angle) < 0)
                or (y > H - margin and math.sin(angle) > 0)
            )
            if inside and outward:
                target = math.atan2(H / 2 - y, W / 2 - x)
                diff = (target - angle + math.pi) % (2 * math.pi) - math.pi
                angle += max(-STEER_RATE, min(STEER_RATE, diff))
            pos = pos + motion.speeds[k - 1] * np.array([math.cos(angle), math.sin(angle)])
        out[k] = (pos[0], pos[1], angle)
    return out


def _entry(rng: np.random.Generator, config: SmallObjectsConfig) -> tuple[np.ndarray, float]:
    """A point just outside a random border and a heading into the central area."""
    W, H = config.width, config.height
    out = config.object_size_range[1] / 2 + 1
    along = rng.uniform(0.1, 0.9)
    start = {
        0: (-out, along * H),
        1: (W + out, along * H),
        2: (along * W, -out),
        3: (along * W, H + out),
    }[int(rng.integers(4))]
    goal = rng.uniform((0.25 * W, 0.25 * H), (0.75 * W, 0.75 * H))
    return np.array(start), math.atan2(goal[1] - start[1], goal[0] - start[0])


@dataclass(eq=False)
class _Plan:
    """One mover before its sprites are known: role, path and when it may be in the scene."""

    role: str
    path: np.ndarray  # (N, 3) x, y, heading; NaN before birth
    anchor: int  # its time in the scene is the run of frames in view that contains this frame
    partner: int = 0
    cap: float = math.inf  # px, largest box side (to be hidden completely behind its occluder)


def _narrowest(mask: np.ndarray, x: int, y: int, rng: np.random.Generator) -> float:
    """A direction (rad) of one of the shortest chords of ``mask`` through (x, y) (at most 30 %
    longer than the shortest): a quick way across. A chord reaching the frame border is endless."""
    H, W = mask.shape
    angles = np.arange(18) * math.pi / 18
    chords = []
    for angle in angles:
        step = np.array([math.cos(angle), math.sin(angle)])
        length = 0.0
        for sign in (1.0, -1.0):
            for r in range(1, H + W):
                px, py = (np.array([x, y]) + sign * r * step).round().astype(int)
                if not (0 <= px < W and 0 <= py < H):
                    length = math.inf
                    break
                if not mask[py, px]:
                    length += r
                    break
        chords.append(length)
    lengths = np.array(chords)
    if not np.isfinite(lengths.min()):
        return float(rng.uniform(0, math.pi))
    shortest = np.flatnonzero(lengths <= 1.3 * lengths.min())
    return float(angles[int(rng.choice(shortest))])


def _plans(
    rng: np.random.Generator, config: SmallObjectsConfig, occluders: list[_Occluder]
) -> tuple[list[_Plan], list[int]]:
    """Every mover's path in id order: crossing pairs, one behind each occluder, then the free
    ones; and the crossing frames (one per pair)."""
    W, H, n = config.width, config.height, config.num_frames
    lo_t, hi_t = round(0.25 * (n - 1)), round(0.75 * (n - 1))
    union = np.zeros((H, W), bool)
    for occ in occluders:
        union |= occ.mask
    clear = cv2.distanceTransform((~union).astype(np.uint8), cv2.DIST_L2, 5)
    depth = _inside_depth(union)
    plans: list[_Plan] = []
    meets: list[int] = []
    for _ in range(config.crossings):
        # where both are seen: the candidate farthest from the occluders (enough if far enough)
        candidates = rng.uniform((0.2 * W, 0.2 * H), (0.8 * W, 0.8 * H), size=(30, 2))
        room = clear[candidates[:, 1].astype(int), candidates[:, 0].astype(int)]
        enough = np.flatnonzero(room > 1.5 * config.object_size_range[1])
        point = candidates[int(enough[0]) if len(enough) else int(np.argmax(room))]
        frame = int(rng.integers(lo_t, hi_t + 1))
        first = rng.uniform(0, 2 * math.pi)
        second = first + rng.choice([-1.0, 1.0]) * rng.uniform(0.5, math.pi - 0.5)
        a, b = len(plans) + 1, len(plans) + 2
        for heading, partner in ((first, b), (second, a)):
            path = _anchored(_Motion.draw(rng, config), frame, point, heading)
            plans.append(_Plan("crossing", path, frame, partner))
        meets.append(frame)
    for occ in occluders[: config.num_objects - len(plans)]:
        inner = np.where(occ.mask, depth, 0.0)
        y, x = np.unravel_index(int(np.argmax(inner)), inner.shape)
        frame = int(rng.integers(lo_t, hi_t + 1))
        across = _narrowest(union, int(x), int(y), rng)
        heading = across + (math.pi if rng.uniform() < 0.5 else 0.0)
        lo_v, hi_v = config.speed_range  # in the faster half: across in a few frames
        motion = _Motion.draw(
            rng, dataclasses.replace(config, speed_range=((lo_v + hi_v) / 2, hi_v))
        )
        path = _anchored(motion, frame, np.array([x + 0.5, y + 0.5]), heading)
        cap = math.sqrt(2) * float(inner[y, x]) - 2  # its box fits in the occluder there
        plans.append(_Plan("occluded", path, frame, cap=cap))
    for _ in range(config.num_objects - len(plans)):
        motion = _Motion.draw(rng, config)
        late = rng.uniform() < config.late_fraction and n > 1
        birth = int(rng.integers(1, max(2, round(0.7 * n)))) if late else 0
        if late and rng.uniform() < 0.5:
            point, heading = _entry(rng, config)
        else:
            point, heading = rng.uniform((0, 0), (W, H)), rng.uniform(0, 2 * math.pi)
        if rng.uniform() < STAY_SHARE:
            path = _steered(motion, birth, point, heading, config)
        else:
            path = _anchored(motion, birth, point, heading)
            path[:birth] = np.nan
        plans.append(_Plan("free", path, birth))
    return plans, meets


# --- movers ------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class _Mover:
    info: SmallMover
    bank: list[_Sprite]
    corner: np.ndarray  # (N, 2) int, where the frame's sprite's top-left corner goes
    bin: np.ndarray  # (N,) int, the frame's sprite (heading bin)


def _placement(bank: list[_Sprite], path: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per frame the sprite (heading bin) and its top-left corner (px, int)."""
    headings = np.nan_to_num(path[:, 2])
    bins = np.round(headings / (2 * math.pi / HEADINGS)).astype(int) % HEADINGS
    offsets = np.array([(s.x0, s.y0) for s in bank])[bins]
    centres = np.round(np.nan_to_num(path[:, :2], nan=-1e6)).astype(np.int64)
    return bins, centres + offsets


def _in_scene(
    bank: list[_Sprite], bins: np.ndarray, corner: np.ndarray, plan: _Plan, shape: tuple[int, int]
) -> np.ndarray:
    """The frames the mover is in the scene: the run of frames with any of its sprite inside
    the frame that holds its anchor frame (for a free mover: the first run from its birth)."""
    H, W = shape
    sizes = np.array([s.mask.shape[::-1] for s in bank])[bins]
    seen = (
        ~np.isnan(plan.path[:, 0])
        & (corner[:, 0] < W)
        & (corner[:, 1] < H)
        & (corner[:, 0] + sizes[:, 0] > 0)
        & (corner[:, 1] + sizes[:, 1] > 0)
    )
    present = np.zeros(len(seen), bool)
    if plan.role == "free":
        after = np.flatnonzero(seen[plan.anchor :])
        if not len(after):
            return present
        start = plan.anchor + int(after[0])
    else:
        start = plan.anchor
        if not seen[start]:
            return present
        while start > 0 and seen[start - 1]:
            start -= 1
    end = start
    while end < len(seen) and seen[end]:
        end += 1
    present[start:end] = True
    return present


def _ground_near(background: np.ndarray, path: np.ndarray) -> np.ndarray:
    """The median ground colour around the middle of a path."""
    H, W = background.shape[:2]
    points = path[~np.isnan(path[:, 0]), :2]
    if not len(points):
        everywhere: np.ndarray = np.median(background.reshape(-1, 3), axis=0).astype(np.float32)
        return everywhere
    x, y = np.clip(points[len(points) // 2], 0, (W - 1, H - 1)).astype(int)
    patch = background[max(0, y - 20) : y + 21, max(0, x - 20) : x + 21]
    nearby: np.ndarray = np.median(patch.reshape(-1, 3), axis=0).astype(np.float32)
    return nearby


def _movers(
    rng: np.random.Generator,
    config: SmallObjectsConfig,
    plans: list[_Plan],
    background: np.ndarray,
) -> list[_Mover]:
    lo, hi = config.object_size_range
    spreads = {species: _spread(species) for species in SPECIES}
    depths = rng.permutation(len(plans))
    movers = []
    for index, plan in enumerate(plans):
        species = str(rng.choice(SPECIES, p=SPECIES_WEIGHTS))
        faint = bool(rng.uniform() < config.low_contrast)
        look = _random_look(rng, species, _ground_near(background, plan.path), faint)
        top = max(min(hi, plan.cap), lo * spreads[species])
        target = rng.uniform(min(lo * spreads[species], top), top)
        bank, length = _sized_bank(species, look, target, (lo, hi))
        bins, corner = _placement(bank, plan.path)
        present = _in_scene(bank, bins, corner, plan, background.shape[:2])
        path = plan.path.copy()
        path[~present] = np.nan
        info = SmallMover(
            index + 1,
            species,
            plan.role,
            plan.partner,
            round(length, 2),
            int(depths[index]),
            path[:, :2],
            path[:, 2],
        )
        movers.append(_Mover(info, bank, corner, bins))
    return movers


# --- rendering ---------------------------------------------------------------------------------


def _render(
    canvas: np.ndarray,
    label: np.ndarray,
    n: int,
    movers: list[_Mover],
    free: np.ndarray,
    min_visibility: float,
) -> list[GroundTruthBox]:
    """Draw frame n's movers far to near on ``canvas`` and ``label`` (not where ``free`` is
    False: the occluders) and return their ground-truth boxes."""
    H, W = label.shape
    drawn: list[tuple[int, _Sprite, tuple[int, int, int, int]]] = []
    for mover in movers:  # sorted far to near
        if not mover.info.present[n]:
            continue
        sprite = mover.bank[int(mover.bin[n])]
        x, y = (int(v) for v in mover.corner[n])
        h, w = sprite.mask.shape
        x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + w, W), min(y + h, H)
        sub = sprite.mask[y0 - y : y1 - y, x0 - x : x1 - x] & free[y0:y1, x0:x1]
        canvas[y0:y1, x0:x1][sub] = sprite.colour[y0 - y : y1 - y, x0 - x : x1 - x][sub]
        label[y0:y1, x0:x1][sub] = mover.info.object_id
        drawn.append((mover.info.object_id, sprite, (x0, y0, x1, y1)))
    boxes = []
    for object_id, sprite, (x0, y0, x1, y1) in sorted(drawn, key=lambda d: d[0]):
        mine = label[y0:y1, x0:x1] == object_id
        count = int(mine.sum())
        if count:
            rows, cols = np.flatnonzero(mine.any(axis=1)), np.flatnonzero(mine.any(axis=0))
            x0, y0, x1, y1 = x0 + cols[0], y0 + rows[0], x0 + cols[-1] + 1, y0 + rows[-1] + 1
        # else hidden: its whole sprite's box in the frame, where it is
        visibility = round(count / sprite.pixels, 4)
        boxes.append(
            GroundTruthBox(
                n,
                object_id,
                float(x0),
                float(y0),
                float(x1 - x0),
                float(y1 - y0),
                visibility,
                0 if visibility < min_visibility or count == 0 else 1,
            )
        )
    return boxes


def generate_small_objects(
    config: SmallObjectsConfig, background: np.ndarray | None = None
) -> SmallObjectsScene:
    """Render the small-object scene ``config`` describes, over ``background`` (any BGR or grey
    image, resized to the scene size) or, without one, a ground generated from the seed.
    Deterministic: the same config and background give bit-identical frames."""
    streams = [np.random.default_rng(s) for s in np.random.SeedSequence(config.seed).spawn(4)]
    background_rng, occluder_rng, mover_rng, sensor_rng = streams
    N, H, W = config.num_frames, config.height, config.width
    ground = (
        _generated_ground(background_rng, W, H)
        if background is None
        else fit_background(background, W, H, 0)
    )
    occluders = _occluders(occluder_rng, config)
    world = ground.copy()
    occluded = np.zeros((H, W), bool)
    for occ in occluders:
        world[occ.mask] = np.clip(np.rint(occ.colour[occ.mask]), 0, 255).astype(np.uint8)
        occluded |= occ.mask
    plans, meets = _plans(mover_rng, config, occluders)
    movers = _movers(mover_rng, config, plans, ground)
    order = sorted(movers, key=lambda m: m.info.depth)
    free = ~occluded
    light_phases = sensor_rng.uniform(0, 2 * math.pi, size=2)
    frames = np.empty((N, H, W, 3), np.uint8)
    labels = np.zeros((N, H, W), np.uint16)
    boxes: list[list[GroundTruthBox]] = []
    for n in range(N):
        canvas = world.copy()
        boxes.append(_render(canvas, labels[n], n, order, free, config.min_visibility))
        frames[n] = sensor_effects(
            canvas, illumination_gain(config, n, light_phases), sensor_rng, config
        )
    crossings = [(2 * i + 1, 2 * i + 2, frame) for i, frame in enumerate(meets)]
    return SmallObjectsScene(
        frames,
        float(config.fps),
        labels,
        boxes,
        np.zeros((N, 2), np.int64),
        config,
        movers=[m.info for m in movers],
        crossings=crossings,
        occluder_mask=occluded,
    )
