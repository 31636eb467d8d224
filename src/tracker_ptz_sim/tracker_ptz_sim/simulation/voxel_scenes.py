"""Voxel scenes: occupancy volumes of people in a room, with ground-truth centroids (no rclpy).

The synthetic evaluation scene of seed 002 (per-person particle filters on voxels): what a
multi-camera visual-hull reconstruction gives per frame, a binary occupancy grid of the
4 x 5 x 2.1 m room (:data:`ROOM_SIZE_M`), with the true centroid of every person.

Geometry. The grid's origin is the room's corner (0, 0, 0), z up (REP-103); voxel (i, j, k) is the
cube whose centre is ``(index + 0.5) * voxel_size`` metres (:func:`grid_shape` cells per axis). A
person is a vertical elliptic cylinder (semi-axes 0.15-0.2 m across the shoulders, 0.12-0.15 m
front to back, the shoulders across the walking direction) from the floor to ``height - 2 r``,
with a head sphere of radius r ~ 0.1 m on top (heights 1.5-1.9 m), all drawn per person. A voxel is
occupied when its centre is inside a body. The ground truth is the body volume's centre of mass
(exact, before rasterising and noise); people keep their ids 1..people for the whole sequence.

Motion. People walk on the floor, all simulated together at the frame rate: a smooth random walk
(the velocity integrates a low-pass random acceleration and reverts to a preferred speed per
person; 0.3-1.2 m/s), reflected off the walls 0.3 m inside the room (so every body stays inside),
and pushed away from anyone closer than 0.8 m. With ``contacts`` (and two people or more) it is
choreographed around scripted events, alternately:

- a long contact: two people converge, walk side by side with their bodies touching (centroid
  distance 0.35-0.45 m, the sum of their shoulder semi-axes) on a gentle arc for 1.2-2 s (30-50
  frames at 25 fps), then diverge;
- a crossing: two people walk straight lines 75-180 degrees apart that pass within 0.25-0.45 m of
  each other at the same moment.

Events are scheduled one after the other (the pair free the earliest goes next, preferring pairs
that have not met yet), at least 0.5 m from the walls and clear of other people's events at about
the same time. During an event its two people follow the script exactly; before it they are
guided to its start (position and velocity, in time: the random walk fades out over the last
3 s, so people may slow down or hurry up to 1.5 m/s) and ignore each other's push. The first
contact and the first crossing fit in 10 s (250 frames at 25 fps); shorter sequences get the
events that fit, and the schedule depends on ``frames`` (a shorter scene is not a prefix of a
longer one). Unscripted encounters remain possible but rare (with 6 people, two bodies overlap
outside events in 1-2 % of the frames). People do not see the furniture; it is placed where nobody
walks instead (below).

Noise, per frame: ``hole_rate`` of the people's voxels are dropped at random (reconstruction
holes), and each cell of the room is switched on with probability ``salt_rate`` (their count drawn
from a binomial over the room's cells, then random cells). Static spurious blobs are present in
every frame, unchanged, at random places and yaws at least 0.4 m from the walls and, where such a
place exists, 0.35 m plus their radius from every person's path (people walk around furniture; a
person walking through a chair merges with it, which no reconstruction shows), in this order: a
chair as a visual hull sees it (the space under the seat is not carved; it passes the seed's
person test "voxels x voxel edge (cm) > 3000 and vertical extent >= 60 cm"), a jacket hanging from
1.05 m down to 0.5 m (enough voxels, too short: it fails), a carved chair (seat slab, back and legs:
passes at 2 cm, fails at 3-4 cm) and a storage box (too low: fails); then again from the start.

Randomness: every choice comes from ``numpy.random`` streams spawned from ``SeedSequence(seed)``:
one for the people (shapes, events, walks), one for the spurious blobs, one per frame for the
noise. The trajectories therefore do not depend on the voxel size, the noise or the blobs, and
:func:`truth_tracks` / :func:`contact_intervals` / :func:`scene_events` never rasterise.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from tracker_msgs_py.params import check_config

ROOM_SIZE_M = (4.0, 5.0, 2.1)  # x, y, z extent of the thesis's room, metres
WALL_MARGIN_M = 0.3  # people's centroids stay this far from the walls
EVENT_MARGIN_M = 0.5  # scripted events stay this far from the walls
BLOB_WALL_CLEARANCE_M = 0.4  # spurious blobs' footprints stay this far from the walls
PATH_CLEARANCE_M = 0.35  # ... and this far from every person's centroid path, when they can
CONTACT_DISTANCE_M = 0.6  # contact_intervals: horizontal centroid distance below this
SPEED_RANGE = (0.3, 1.2)  # m/s, free walks
MAX_PEOPLE = 6
MAX_SPURIOUS = 8

_ACC_SIGMA = 0.5  # m/s^2, spread of the low-pass random acceleration
_ACC_TAU = 1.0  # s, its correlation time
_SPEED_GAIN = 0.8  # 1/s, reversion to the preferred speed
_TRAVEL_SPEED = 0.7  # m/s, distance a person may cover per second between two events
_GUIDED_MAX_SPEED = 1.5  # m/s, on the way to an event's start
_GUIDANCE_MAX_ACC = 4.0  # m/s^2
_REPULSION_RANGE_M = 0.8  # people out of events keep about this far from one another
_REPULSION_ACC = 10.0  # m/s^2, the push at zero distance
_CONTACT_S = (1.2, 2.0)  # s, length of a scripted contact (touching)
_MERGE_S = 0.8  # s, converging before a contact and diverging after it
_CROSSING_HALF_S = (0.5, 0.8)  # s, scripted straight walk before (and after) a crossing (at least)
_CLASH_PAD_S = 1.5  # s, events of other people keep apart this long before and after
_EVENT_DRAWS = 8  # an event's place and script: the earliest of this many draws
_MAX_EVENTS = 1000

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]
PathFn = Callable[[FloatArray], FloatArray]  # times (n,) s -> positions (n, 2) m


@dataclass(frozen=True)
class VoxelSceneConfig:
    """Everything that defines a voxel scene; the same config always gives the same frames."""

    people: int = 4  # 1..6 (events need 2)
    frames: int = 250
    fps: float = 25.0
    voxel_size: float = 0.02  # metres (2, 3, 4 cm are used)
    hole_rate: float = 0.05  # share of a person's voxels dropped per frame (reconstruction holes)
    salt_rate: float = 2e-4  # share of empty voxels (inside the room) switched on per frame
    spurious: int = 2  # persistent static spurious blobs (chair, jacket, carved chair, box, ...)
    contacts: bool = True  # force crossings and long contacts (side by side, touching, 1-2 s)
    seed: int = 0

    def __post_init__(self) -> None:
        check_config(self)

    def problems(self) -> list[str]:
        """Why this scene cannot be generated (empty: it can)."""
        c, problems = self, []
        if not 1 <= c.people <= MAX_PEOPLE:
            problems.append(f"people must be in [1, {MAX_PEOPLE}], got {c.people}")
        if c.frames < 1:
            problems.append(f"frames must be >= 1, got {c.frames}")
        if not (math.isfinite(c.fps) and c.fps > 0):
            problems.append(f"fps must be positive, got {c.fps}")
        if not 0.01 <= c.voxel_size <= 0.1:
            problems.append(f"voxel_size must be in [0.01, 0.1] m, got {c.voxel_size}")
        if not 0.0 <= c.hole_rate < 1.0:
            problems.append(f"hole_rate must be in [0, 1), got {c.hole_rate}")
        if not 0.0 <= c.salt_rate <= 0.01:
            problems.append(f"salt_rate must be in [0, 0.01], got {c.salt_rate}")
        if not 0 <= c.spurious <= MAX_SPURIOUS:
            problems.append(f"spurious must be in [0, {MAX_SPURIOUS}], got {c.spurious}")
        if c.seed < 0:
            problems.append(f"seed must be >= 0, got {c.seed}")
        return problems


@dataclass(frozen=True)
class VoxelFrame:
    """One frame: the occupied voxels and the people's true centroids."""

    index: int
    time: float  # s
    voxels: (
        np.ndarray
    )  # (P, 3) int32 (i, j, k), sorted, unique; centre = (index + 0.5) * voxel_size
    truth_ids: np.ndarray  # (m,) int: person ids
    truth_centroids: np.ndarray  # (m, 3) metres: centroid of each person's body volume


@dataclass(frozen=True)
class SceneEvent:
    """A scripted event: people ``a`` and ``b`` (ids) follow the script in frames first..last;
    ``core`` is the frames in which they touch side by side (contact), or the frame of their
    closest approach twice (crossing)."""

    kind: str  # "contact" (side by side, touching) or "crossing"
    a: int
    b: int
    first: int
    last: int
    core: tuple[int, int]


@dataclass(frozen=True)
class SpuriousBlob:
    """A static spurious blob: its kind, where it stands and its voxels (as in every frame)."""

    kind: str  # "chair", "jacket", "carved_chair" or "box"
    centre: tuple[float, float]  # m, centre of its footprint
    yaw: float  # rad
    voxels: np.ndarray  # (n, 3) int32


@dataclass(frozen=True)
class _Shape:
    """A person's body: elliptic cylinder (shoulder x depth semi-axes) plus a head sphere."""

    shoulder: float  # m, semi-axis across the walking direction
    depth: float  # m, semi-axis along it
    height: float  # m, top of the head
    head: float  # m, head radius

    @property
    def body_top(self) -> float:
        """Top of the cylinder (the head sphere stands on it)."""
        return self.height - 2.0 * self.head

    @property
    def centroid_z(self) -> float:
        """Height of the centre of mass of cylinder plus head."""
        cylinder = math.pi * self.shoulder * self.depth * self.body_top
        sphere = 4.0 / 3.0 * math.pi * self.head**3
        moment = cylinder * self.body_top / 2.0 + sphere * (self.height - self.head)
        return moment / (cylinder + sphere)


@dataclass(frozen=True)
class _Segment:
    """A scripted piece of one person's path: positions from frame ``first`` on."""

    first: int
    xy: FloatArray  # (n, 2) m
    v: FloatArray  # (n, 2) m/s
    partner: int  # the other person of the event (index)

    @property
    def last(self) -> int:
        return self.first + len(self.xy) - 1


@dataclass(frozen=True)
class _Script:
    """An event's two paths (relative to the event's place) over ``frames`` frames; ``core`` its
    core frames (see SceneEvent), counted from the script's first frame."""

    paths: tuple[PathFn, PathFn]
    frames: int
    core: tuple[int, int]


@dataclass(frozen=True)
class _Plan:
    """The people's part of a scene (independent of voxel size and noise)."""

    shapes: tuple[_Shape, ...]
    xy: FloatArray  # (frames, people, 2)
    heading: FloatArray  # (frames, people) rad
    centroids: FloatArray  # (frames, people, 3)
    events: tuple[SceneEvent, ...]


@dataclass(frozen=True)
class _Box:
    """An oriented box of a blob, in the blob's frame (x forward, y left, z up), metres."""

    centre: tuple[float, float, float]
    half: tuple[float, float, float]


_BACK = _Box((-0.2, 0.0, 0.685), (0.025, 0.225, 0.215))  # chair back, 0.47-0.9 m
_LEGS = tuple(
    _Box((sx * 0.2, sy * 0.2, 0.205), (0.02, 0.02, 0.205)) for sx in (-1, 1) for sy in (-1, 1)
)
_BLOB_KINDS: tuple[tuple[str, float, tuple[_Box, ...]], ...] = (  # kind, footprint radius, boxes
    ("chair", 0.33, (_Box((0.0, 0.0, 0.235), (0.225, 0.225, 0.235)), _BACK)),
    ("jacket", 0.23, (_Box((0.0, 0.0, 0.775), (0.05, 0.21, 0.275)),)),
    ("carved_chair", 0.33, (_Box((0.0, 0.0, 0.44), (0.225, 0.225, 0.03)), _BACK, *_LEGS)),
    ("box", 0.33, (_Box((0.0, 0.0, 0.2), (0.25, 0.2, 0.2)),)),
)


# --- public API --------------------------------------------------------------------------------


def grid_shape(voxel_size: float) -> tuple[int, int, int]:
    """Cells per axis of the room's grid: (200, 250, 105) at 0.02 m."""
    x, y, z = (int(round(extent / voxel_size)) for extent in ROOM_SIZE_M)
    return x, y, z


def voxel_scene(config: VoxelSceneConfig) -> Iterator[VoxelFrame]:
    """The scene's frames, generated one at a time (deterministic for a config)."""
    plan = _plan(_people_key(config))
    shape = grid_shape(config.voxel_size)
    static = _static_cells(config, shape)
    noise_seeds = _streams(config.seed)[2].spawn(config.frames)
    ids = np.arange(1, config.people + 1)
    for index in range(config.frames):
        rng = np.random.default_rng(noise_seeds[index])
        cells = _frame_cells(config, plan, index, shape, static, rng)
        voxels = np.stack(np.unravel_index(cells, shape), axis=1).astype(np.int32)
        yield VoxelFrame(
            index, index / config.fps, voxels, ids.copy(), plan.centroids[index].copy()
        )


def truth_tracks(config: VoxelSceneConfig) -> np.ndarray:
    """(frames, people, 3) metres: every person's true centroid per frame (person id = column + 1)."""
    return _plan(_people_key(config)).centroids.copy()


def scene_events(config: VoxelSceneConfig) -> list[SceneEvent]:
    """The scripted contacts and crossings, in scheduling order (empty without ``contacts``)."""
    return list(_plan(_people_key(config)).events)


def contact_intervals(config: VoxelSceneConfig) -> list[tuple[int, int, int, int]]:
    """(id a, id b, first frame, last frame) of every interval in which two people's horizontal
    centroid distance is below 0.6 m (a < b, sorted by first frame)."""
    xy = _plan(_people_key(config)).xy
    intervals = []
    for a, b in itertools.combinations(range(config.people), 2):
        close = np.linalg.norm(xy[:, a] - xy[:, b], axis=1) < CONTACT_DISTANCE_M
        intervals += [(a + 1, b + 1, first, last) for first, last in _runs(close)]
    return sorted(intervals, key=lambda t: (t[2], t[0], t[1]))


def spurious_blobs(config: VoxelSceneConfig) -> list[SpuriousBlob]:
    """The static spurious blobs and their voxels at ``config.voxel_size``."""
    shape = grid_shape(config.voxel_size)
    blobs = []
    for kind, boxes, centre, yaw in _placed_blobs(config):
        cells = np.unique(_blob_cells(boxes, centre, yaw, config.voxel_size, shape))
        voxels = np.stack(np.unravel_index(cells, shape), axis=1).astype(np.int32)
        blobs.append(SpuriousBlob(kind, (float(centre[0]), float(centre[1])), yaw, voxels))
    return blobs


def dense_grid(frame: VoxelFrame, shape: tuple[int, int, int]) -> np.ndarray:
    """The frame's occupancy as a bool grid of ``shape`` (see :func:`grid_shape`)."""
    grid = np.zeros(shape, dtype=bool)
    v = frame.voxels
    grid[v[:, 0], v[:, 1], v[:, 2]] = True
    return grid


# --- randomness --------------------------------------------------------------------------------


def _streams(seed: int) -> list[np.random.SeedSequence]:
    """Independent streams: people, spurious blobs, per-frame noise."""
    return np.random.SeedSequence(seed).spawn(3)


def _people_key(config: VoxelSceneConfig) -> tuple[int, int, float, bool, int]:
    """The config fields the people's motion depends on (the plan's cache key)."""
    return (config.people, config.frames, config.fps, config.contacts, config.seed)


# --- people: shapes and motion -------------------------------------------------------------------


@functools.lru_cache(maxsize=16)
def _plan(key: tuple[int, int, float, bool, int]) -> _Plan:
    """Shapes, trajectories, events and true centroids of the people (cached, read-only)."""
    people, frames, fps, contacts, seed = key
    rng = np.random.default_rng(_streams(seed)[0])
    shapes = tuple(_random_shape(rng) for _ in range(people))
    events: list[SceneEvent] = []
    segments: list[list[_Segment]] = [[] for _ in range(people)]
    if contacts and people >= 2:
        events, segments = _schedule(shapes, frames, fps, rng)
    xy = _simulate(segments, frames, fps, rng)
    heading = _headings(xy, fps)
    z = np.array([s.centroid_z for s in shapes])
    centroids = np.concatenate([xy, np.broadcast_to(z, (frames, people))[..., None]], axis=2)
    for array in (xy, heading, centroids):
        array.flags.writeable = False
    return _Plan(shapes, xy, heading, centroids, tuple(events))


def _random_shape(rng: np.random.Generator) -> _Shape:
    """A person's body, drawn."""
    return _Shape(
        shoulder=rng.uniform(0.15, 0.2),
        depth=rng.uniform(0.12, 0.15),
        height=rng.uniform(1.5, 1.9),
        head=rng.uniform(0.09, 0.11),
    )


def _headings(xy: FloatArray, fps: float) -> FloatArray:
    """Walking direction per frame and person (0 for a single frame)."""
    if len(xy) < 2:
        return np.zeros(xy.shape[:2])
    v = np.gradient(xy, axis=0) * fps
    return np.arctan2(v[..., 1], v[..., 0])


def _walk_box(margin: float) -> tuple[FloatArray, FloatArray]:
    """Lower and upper corners of the floor area kept ``margin`` from the walls."""
    lo = np.full(2, margin)
    return lo, np.array(ROOM_SIZE_M[:2]) - margin


@dataclass
class _Crowd:
    """Everyone's walking state during the simulation (arrays over people)."""

    segments: list[list[_Segment]]
    fps: float
    pos: FloatArray  # (P, 2) m
    vel: FloatArray  # (P, 2) m/s
    acc: FloatArray  # (P, 2) m/s^2, the low-pass random acceleration
    preferred: FloatArray  # (P,) m/s

    def segment(self, person: int, frame: int) -> _Segment | None:
        """The person's segment running at ``frame`` or the next one, if any."""
        return next((s for s in self.segments[person] if s.last >= frame), None)


def _simulate(
    segments: list[list[_Segment]], frames: int, fps: float, rng: np.random.Generator
) -> FloatArray:
    """(frames, people, 2) positions: scripted segments exactly, in between a random walk guided
    to the next segment, pushed away from the others and reflected off the walls."""
    crowd = _start_crowd(segments, fps, rng)
    alpha = math.exp(-1.0 / (fps * _ACC_TAU))
    noise = rng.standard_normal((frames, len(segments), 2)) * _ACC_SIGMA * math.sqrt(1 - alpha**2)
    xy = np.empty((frames, len(segments), 2))
    for frame in range(frames):
        if frame:
            crowd.acc = alpha * crowd.acc + noise[frame]
            _step(crowd, frame)
        _lock(crowd, frame)
        xy[frame] = crowd.pos
    _fix_arrivals(xy, segments, fps)
    return np.clip(xy, *_walk_box(WALL_MARGIN_M))


def _start_crowd(segments: list[list[_Segment]], fps: float, rng: np.random.Generator) -> _Crowd:
    """Initial states: on the way to the first segment (walked back from its start), or anywhere
    0.8 m from the others for people without events."""
    people = len(segments)
    pos, vel = np.empty((people, 2)), np.empty((people, 2))
    lo, hi = _walk_box(WALL_MARGIN_M)
    for p, segs in enumerate(segments):
        if segs:
            back = -segs[0].v[0] * segs[0].first / fps  # walked back from the segment's start
            back *= _inside_share(segs[0].xy[0], back, lo, hi)
            pos[p] = np.clip(segs[0].xy[0] + back + rng.normal(0.0, 0.05, 2), lo, hi)
            vel[p] = segs[0].v[0]
    taken = [pos[p] for p in range(people) if segments[p]]
    for p in (p for p in range(people) if not segments[p]):
        pos[p] = _spot(lo, hi, taken, _REPULSION_RANGE_M, rng)
        taken.append(pos[p])
        angle = rng.uniform(0.0, 2.0 * math.pi)
        vel[p] = rng.uniform(0.4, 1.0) * np.array([math.cos(angle), math.sin(angle)])
    return _Crowd(segments, fps, pos, vel, np.zeros((people, 2)), rng.uniform(0.5, 1.0, people))


def _inside_share(start: FloatArray, step: FloatArray, lo: FloatArray, hi: FloatArray) -> float:
    """The largest share of ``step`` that keeps ``start + share * step`` in the box [lo, hi]."""
    with np.errstate(divide="ignore", invalid="ignore"):
        limits = np.where(
            step > 0, (hi - start) / step, np.where(step < 0, (lo - start) / step, np.inf)
        )
    return float(np.clip(np.min(limits), 0.0, 1.0))


def _spot(
    lo: FloatArray, hi: FloatArray, taken: list[FloatArray], gap: float, rng: np.random.Generator
) -> FloatArray:
    """A uniform point of the box [lo, hi] at least ``gap`` from ``taken`` (the last of 200 draws
    if none is)."""
    point = rng.uniform(lo, hi)
    for _ in range(200):
        if all(np.linalg.norm(point - t) >= gap for t in taken):
            break
        point = rng.uniform(lo, hi)
    return point


def _step(crowd: _Crowd, frame: int) -> None:
    """Moves everyone from frame - 1 to ``frame`` (scripted people are put right by _lock)."""
    tau, target_pos, target_vel, partner = _targets(crowd, frame)
    share = np.clip((tau - 1.0) / 2.0, 0.0, 1.0)[:, None]  # random walk fades 3 s -> 1 s before
    pull = _SPEED_GAIN * (crowd.preferred[:, None] - _norms(crowd.vel)) * _units(crowd.vel)
    acc = share * (crowd.acc + pull) + _repulsion(crowd.pos, partner)
    acc += _guidance(crowd.pos, crowd.vel, tau, target_pos, target_vel)
    vel = crowd.vel + acc / crowd.fps
    free = share[:, 0] >= 1.0
    vel = _clamp_speeds(
        vel, np.where(free, SPEED_RANGE[0], 0.0), np.where(free, SPEED_RANGE[1], _GUIDED_MAX_SPEED)
    )
    crowd.pos, crowd.vel, crowd.acc = _reflect(crowd.pos + vel / crowd.fps, vel, crowd.acc)


def _targets(
    crowd: _Crowd, frame: int
) -> tuple[FloatArray, FloatArray, FloatArray, npt.NDArray[np.intp]]:
    """Per person: time (s) from frame - 1 to its next segment's start (inf: none), that start's
    position and velocity, and the partner of that segment (-1: none)."""
    people = len(crowd.segments)
    tau, partner = np.full(people, np.inf), np.full(people, -1, dtype=np.intp)
    target_pos, target_vel = np.zeros((people, 2)), np.zeros((people, 2))
    for p in range(people):
        s = crowd.segment(p, frame)
        if s is not None and s.first >= frame:
            tau[p] = (s.first - frame + 1) / crowd.fps
            target_pos[p], target_vel[p], partner[p] = s.xy[0], s.v[0], s.partner
    return tau, target_pos, target_vel, partner


def _norms(v: FloatArray) -> FloatArray:
    """(n, 1) lengths of the rows of ``v``."""
    norms: FloatArray = np.linalg.norm(v, axis=1, keepdims=True)
    return norms


def _units(v: FloatArray) -> FloatArray:
    """Rows of ``v`` scaled to length 1 (zero rows stay zero)."""
    return v / np.maximum(_norms(v), 1e-9)


def _repulsion(pos: FloatArray, partner: npt.NDArray[np.intp]) -> FloatArray:
    """(P, 2) m/s^2 pushing everyone away from the others closer than _REPULSION_RANGE_M, except
    from the partner of one's next event."""
    diff = pos[:, None] - pos[None]
    d = np.linalg.norm(diff, axis=2)
    near = d < _REPULSION_RANGE_M
    np.fill_diagonal(near, False)
    has = partner >= 0
    near[np.flatnonzero(has), partner[has]] = False
    magnitude = np.where(
        near, _REPULSION_ACC * (1.0 - d / _REPULSION_RANGE_M) / np.maximum(d, 1e-6), 0.0
    )
    acceleration: FloatArray = (magnitude[..., None] * diff).sum(axis=1)
    return acceleration


def _guidance(
    pos: FloatArray,
    vel: FloatArray,
    tau: FloatArray,
    target_pos: FloatArray,
    target_vel: FloatArray,
) -> FloatArray:
    """(P, 2) m/s^2: the initial acceleration of the cubic from (pos, vel) reaching (target_pos,
    target_vel) in tau seconds (capped; zero without a target)."""
    acc = np.zeros_like(pos)
    m = np.isfinite(tau)
    t = tau[m][:, None]
    acc[m] = (6.0 * (target_pos[m] - pos[m]) - 2.0 * t * (2.0 * vel[m] + target_vel[m])) / t**2
    return acc * np.minimum(1.0, _GUIDANCE_MAX_ACC / np.maximum(_norms(acc), 1e-9))


def _clamp_speeds(vel: FloatArray, low: FloatArray, high: FloatArray) -> FloatArray:
    """Velocities rescaled to speeds in [low, high] (per row; a zero velocity stays zero)."""
    speed = _norms(vel)
    return vel * np.clip(speed, low[:, None], high[:, None]) / np.maximum(speed, 1e-9)


def _reflect(
    pos: FloatArray, vel: FloatArray, acc: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Positions mirrored at the walls (WALL_MARGIN_M inside), the velocities and random
    accelerations pointing back into the room."""
    lo, hi = _walk_box(WALL_MARGIN_M)
    below, above = pos < lo, pos > hi
    pos = np.clip(np.where(below, 2 * lo - pos, np.where(above, 2 * hi - pos, pos)), lo, hi)
    inward = np.where(below, 1.0, np.where(above, -1.0, 0.0))
    vel = np.where(inward != 0, inward * np.abs(vel), vel)
    acc = np.where(inward != 0, inward * np.abs(acc), acc)
    return pos, vel, acc


def _lock(crowd: _Crowd, frame: int) -> None:
    """Puts everyone in a scripted segment at ``frame`` where the script says."""
    for p in range(len(crowd.segments)):
        s = crowd.segment(p, frame)
        if s is not None and s.first <= frame:
            crowd.pos[p], crowd.vel[p] = s.xy[frame - s.first], s.v[frame - s.first]


def _fix_arrivals(xy: FloatArray, segments: list[list[_Segment]], fps: float) -> None:
    """Removes (in place) the guidance's miss of each segment's start: the walk's last second (or
    more, for a larger miss) before a segment is bent smoothly onto it."""
    for p, segs in enumerate(segments):
        free_from = 0
        for s in segs:
            if s.first > free_from:
                miss = xy[s.first - 1, p] - (s.xy[0] - s.v[0] / fps)
                seconds = max(1.0, 1.5 * float(np.linalg.norm(miss)) / 0.4)  # at most +0.4 m/s
                begin = max(free_from, s.first - round(seconds * fps))
                ramp = (np.arange(1, s.first - begin + 1) / (s.first - begin))[:, None]
                xy[begin : s.first, p] -= ramp**2 * (3.0 - 2.0 * ramp) * miss
            free_from = s.last + 1


# --- people: scripted events ---------------------------------------------------------------------


def _schedule(
    shapes: tuple[_Shape, ...], frames: int, fps: float, rng: np.random.Generator
) -> tuple[list[SceneEvent], list[list[_Segment]]]:
    """Contacts and crossings, alternately, as long as they fit in the sequence."""
    segments: list[list[_Segment]] = [[] for _ in shapes]
    ready = [round(rng.uniform(0.2, 0.8) * fps) for _ in shapes]
    events: list[SceneEvent] = []
    previous: tuple[int, int] | None = None
    for k in range(_MAX_EVENTS):
        kind = ("contact", "crossing")[k % 2]
        pair = _pick_pair(segments, ready, previous, events, rng)
        rest = rng.uniform(0.5, 1.5) if k < 2 else rng.uniform(1.5, 4.0)
        placed = _place_event(kind, pair, shapes, segments, ready, rest, frames, fps, rng)
        if placed is None:
            break
        script, (seg_a, seg_b) = placed
        segments[pair[0]].append(seg_a)
        segments[pair[1]].append(seg_b)
        core = (seg_a.first + script.core[0], seg_a.first + script.core[1])
        events.append(SceneEvent(kind, pair[0] + 1, pair[1] + 1, seg_a.first, seg_a.last, core))
        previous = pair
    return events, segments


def _pick_pair(
    segments: list[list[_Segment]],
    ready: list[int],
    previous: tuple[int, int] | None,
    events: list[SceneEvent],
    rng: np.random.Generator,
) -> tuple[int, int]:
    """The pair free the earliest (random among ties; each earlier event of the pair counts as
    100 frames later), not ``previous`` unless it is the only one."""
    free = [s[-1].last if s else r for s, r in zip(segments, ready, strict=True)]
    pairs = list(itertools.combinations(range(len(segments)), 2))
    pairs = [p for p in pairs if p != previous] or pairs
    met = [sum(e.a == a + 1 and e.b == b + 1 for e in events) for a, b in pairs]
    keys = [
        max(free[a], free[b]) + 100 * m + rng.random() for (a, b), m in zip(pairs, met, strict=True)
    ]
    return pairs[int(np.argmin(keys))]


def _place_event(
    kind: str,
    pair: tuple[int, int],
    shapes: tuple[_Shape, ...],
    segments: list[list[_Segment]],
    ready: list[int],
    rest: float,
    frames: int,
    fps: float,
    rng: np.random.Generator,
) -> tuple[_Script, tuple[_Segment, _Segment]] | None:
    """The script and the pair's segments of a new event: of a few draws, the one that can start
    the earliest (clear of the other events); None when none fits in time."""
    lasts = [segments[p][-1] if segments[p] else None for p in pair]
    known = [s.xy[-1] for s in lasts if s is not None]
    target = np.mean(known, axis=0) if known else None
    best: tuple[_Script, tuple[_Segment, _Segment]] | None = None
    for _ in range(_EVENT_DRAWS):
        if kind == "contact":
            script = _contact_script(shapes[pair[0]], shapes[pair[1]], fps, rng)
        else:
            script = _crossing_script(fps, rng)
        offset = _placement(script, fps, target, rng)
        if offset is None:
            continue
        t = np.arange(script.frames) / fps
        starts = [f(t[:1])[0] + offset for f in script.paths]
        waits = zip(lasts, [ready[p] for p in pair], starts, strict=True)
        earliest = max(_ready_at(last, r, start, rest, fps) for last, r, start in waits)
        latest = frames - script.frames if best is None else best[1][0].first - 1
        base = (
            _segment(script.paths[0], offset, 0, t, pair[1]),
            _segment(script.paths[1], offset, 0, t, pair[0]),
        )
        for first in range(earliest, latest + 1, max(1, round(fps / 4))):
            placed = (replace(base[0], first=first), replace(base[1], first=first))
            if not _clashes(placed, segments, pair, fps):
                best = script, placed
                break
    return best


def _ready_at(last: _Segment | None, ready: int, start: FloatArray, rest: float, fps: float) -> int:
    """First frame a person can start a new segment at ``start``: after a rest and the walk there."""
    if last is None:
        return ready
    distance = float(np.linalg.norm(start - last.xy[-1]))
    return last.last + math.ceil(fps * (rest + distance / _TRAVEL_SPEED))


def _clashes(
    placed: tuple[_Segment, ...], segments: list[list[_Segment]], pair: tuple[int, int], fps: float
) -> bool:
    """Whether a new event's segments come within _REPULSION_RANGE_M of other people's segments
    at about the same time (segments padded by _CLASH_PAD_S, standing at their ends)."""
    pad = round(_CLASH_PAD_S * fps)
    others = [s for p, segs in enumerate(segments) if p not in pair for s in segs]
    for new, old in itertools.product(placed, others):
        frames = np.arange(max(new.first, old.first) - pad, min(new.last, old.last) + pad + 1)
        if len(frames) and np.min(np.linalg.norm(_at(new, frames) - _at(old, frames), axis=1)) < (
            _REPULSION_RANGE_M
        ):
            return True
    return False


def _at(segment: _Segment, frames: IntArray) -> FloatArray:
    """The segment's positions at ``frames``, standing at its ends outside it."""
    return segment.xy[np.clip(frames - segment.first, 0, len(segment.xy) - 1)]


def _segment(path: PathFn, offset: FloatArray, first: int, t: FloatArray, partner: int) -> _Segment:
    """The segment following ``path`` (shifted by ``offset``) from frame ``first``."""
    h = 1e-4
    velocity = (path(t + h) - path(t - h)) / (2 * h)
    return _Segment(first, path(t) + offset, velocity, partner)


def _placement(
    script: _Script, fps: float, target: FloatArray | None, rng: np.random.Generator
) -> FloatArray | None:
    """An offset keeping both paths EVENT_MARGIN_M from the walls: near ``target`` (the
    participants' last positions) when given, else uniform; None when the paths cannot fit."""
    t = np.arange(script.frames) / fps
    points = np.concatenate([f(t) for f in script.paths])
    box_lo, box_hi = _walk_box(EVENT_MARGIN_M)
    lo, hi = box_lo - points.min(axis=0), box_hi - points.max(axis=0)
    if np.any(lo > hi):
        return None
    if target is None:
        uniform: FloatArray = rng.uniform(lo, hi)
        return uniform
    return np.clip(target + rng.normal(0.0, 0.5, 2), lo, hi)


def _contact_script(a: _Shape, b: _Shape, fps: float, rng: np.random.Generator) -> _Script:
    """Two people converging for _MERGE_S, walking side by side with shoulders touching, then
    diverging for _MERGE_S, all on one gentle arc."""
    merge, touch = round(_MERGE_S * fps), round(rng.uniform(*_CONTACT_S) * fps)
    t0, t1 = merge / fps, (merge + touch - 1) / fps
    speed, turn = rng.uniform(0.5, 0.8), rng.uniform(-0.25, 0.25)
    heading = rng.uniform(0.0, 2.0 * math.pi)
    half = float(np.clip(a.shoulder + b.shoulder + rng.uniform(-0.01, 0.01), 0.35, 0.45)) / 2.0
    side, splay = float(rng.choice([-1.0, 1.0])), rng.uniform(0.35, 0.5)

    def member(sign: float) -> PathFn:
        def path(t: FloatArray) -> FloatArray:
            theta = heading + turn * t
            normal = np.stack([-np.sin(theta), np.cos(theta)], axis=1)
            apart = np.maximum(0.0, np.maximum(t0 - t, t - t1))  # s outside the touching window
            offset = half + splay * (np.sqrt(apart**2 + 0.3**2) - 0.3)  # C1 at the window's ends
            points: FloatArray = (
                _arc(t, speed, turn, heading) + (sign * side * offset)[:, None] * normal
            )
            return points

        return path

    return _Script((member(1.0), member(-1.0)), 2 * merge + touch, (merge, merge + touch - 1))


def _arc(t: FloatArray, speed: float, turn: float, heading: float) -> FloatArray:
    """Positions (relative to the start) on a circular arc walked at ``speed`` turning at ``turn``."""
    if abs(turn) < 1e-6:
        return speed * np.outer(t, [math.cos(heading), math.sin(heading)])
    theta = heading + turn * t
    r = speed / turn
    return np.stack(
        [r * (np.sin(theta) - math.sin(heading)), -r * (np.cos(theta) - math.cos(heading))], axis=1
    )


def _crossing_script(fps: float, rng: np.random.Generator) -> _Script:
    """Two straight walks 75-180 degrees apart, closest (0.25-0.45 m) at the middle frame and at
    least 0.8 m apart at both ends."""
    heading_a = rng.uniform(0.0, 2.0 * math.pi)
    heading_b = heading_a + float(rng.choice([-1.0, 1.0])) * rng.uniform(math.radians(75), math.pi)
    va = rng.uniform(0.6, 1.1) * np.array([math.cos(heading_a), math.sin(heading_a)])
    vb = rng.uniform(0.6, 1.1) * np.array([math.cos(heading_b), math.sin(heading_b)])
    w = va - vb
    speed = float(np.linalg.norm(w))
    half = math.ceil(max(rng.uniform(*_CROSSING_HALF_S), _REPULSION_RANGE_M / speed) * fps)
    middle = half / fps
    gap = rng.uniform(0.25, 0.45) / 2.0 * np.array([-w[1], w[0]]) / speed

    def line(v: FloatArray, sign: float) -> PathFn:
        return lambda t: np.outer(t - middle, v) + sign * gap

    return _Script((line(va, 1.0), line(vb, -1.0)), 2 * half + 1, (half, half))


def _runs(mask: npt.NDArray[np.bool_]) -> list[tuple[int, int]]:
    """(first, last) index of every run of True in ``mask``."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    return [(int(a), int(b)) for a, b in zip(starts, stops, strict=True)]


# --- rasterising ---------------------------------------------------------------------------------


def _frame_cells(
    config: VoxelSceneConfig,
    plan: _Plan,
    index: int,
    shape: tuple[int, int, int],
    static: IntArray,
    rng: np.random.Generator,
) -> IntArray:
    """Sorted unique linear indices of the frame's occupied cells: people with holes, the static
    blobs and salt noise."""
    people = [
        _person_cells(plan.xy[index, p], float(plan.heading[index, p]), s, config.voxel_size, shape)
        for p, s in enumerate(plan.shapes)
    ]
    cells = np.concatenate(people)
    if config.hole_rate > 0.0:
        cells = cells[rng.random(len(cells)) >= config.hole_rate]
    total = shape[0] * shape[1] * shape[2]
    salt = rng.integers(0, total, rng.binomial(total, config.salt_rate))
    occupied = np.zeros(total, dtype=bool)
    for part in (cells, static, salt):
        occupied[part] = True
    return np.flatnonzero(occupied)


def _axis_cells(low: float, high: float, voxel_size: float, count: int) -> IntArray:
    """Indices of the cells (on an axis of ``count``) whose centres may lie in [low, high]."""
    first = max(0, math.floor(low / voxel_size - 0.5))
    stop = min(count, math.ceil(high / voxel_size + 0.5))
    return np.arange(first, max(first, stop))


def _centres(cells: IntArray, voxel_size: float) -> FloatArray:
    """Cell centres (m) of axis indices."""
    return (cells.astype(np.float64) + 0.5) * voxel_size


def _linear(i: IntArray, j: IntArray, k: IntArray, shape: tuple[int, int, int]) -> IntArray:
    """Linear (C-order) cell index."""
    return (i * shape[1] + j) * shape[2] + k


def _person_cells(
    xy: FloatArray, heading: float, body: _Shape, voxel_size: float, shape: tuple[int, int, int]
) -> IntArray:
    """Linear indices of the cells whose centres lie in the person's body (cylinder + head)."""
    x, y = float(xy[0]), float(xy[1])
    r = max(body.shoulder, body.depth)
    ci = _axis_cells(x - r, x + r, voxel_size, shape[0])
    cj = _axis_cells(y - r, y + r, voxel_size, shape[1])
    dx, dy = _centres(ci, voxel_size)[:, None] - x, _centres(cj, voxel_size)[None, :] - y
    c, s = math.cos(heading), math.sin(heading)
    along, across = dx * c + dy * s, dy * c - dx * s
    ii, jj = np.nonzero((along / body.depth) ** 2 + (across / body.shoulder) ** 2 <= 1.0)
    layers = min(shape[2], max(0, math.ceil(body.body_top / voxel_size - 0.5)))
    column = _linear(ci[ii], cj[jj], np.zeros_like(ii), shape)
    cylinder = (column[:, None] + np.arange(layers)[None, :]).ravel()
    head = _ball_cells((x, y, body.height - body.head), body.head, voxel_size, shape)
    return np.concatenate([cylinder, head])


def _ball_cells(
    centre: tuple[float, float, float],
    radius: float,
    voxel_size: float,
    shape: tuple[int, int, int],
) -> IntArray:
    """Linear indices of the cells whose centres lie in a ball."""
    axes = [
        _axis_cells(c - radius, c + radius, voxel_size, n)
        for c, n in zip(centre, shape, strict=True)
    ]
    d = [(_centres(a, voxel_size) - c) ** 2 for a, c in zip(axes, centre, strict=True)]
    inside = d[0][:, None, None] + d[1][None, :, None] + d[2][None, None, :] <= radius**2
    ii, jj, kk = np.nonzero(inside)
    return _linear(axes[0][ii], axes[1][jj], axes[2][kk], shape)


def _box_cells(
    box: _Box, origin: FloatArray, yaw: float, voxel_size: float, shape: tuple[int, int, int]
) -> IntArray:
    """Linear indices of the cells whose centres lie in ``box`` of a blob at ``origin``, ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    bx, by, bz = box.centre
    x, y = origin[0] + bx * c - by * s, origin[1] + bx * s + by * c
    reach = math.hypot(box.half[0], box.half[1])
    ci = _axis_cells(x - reach, x + reach, voxel_size, shape[0])
    cj = _axis_cells(y - reach, y + reach, voxel_size, shape[1])
    ck = _axis_cells(bz - box.half[2], bz + box.half[2], voxel_size, shape[2])
    dx, dy = _centres(ci, voxel_size)[:, None] - x, _centres(cj, voxel_size)[None, :] - y
    along, across = dx * c + dy * s, dy * c - dx * s
    ii, jj = np.nonzero((np.abs(along) <= box.half[0]) & (np.abs(across) <= box.half[1]))
    kk = ck[np.abs(_centres(ck, voxel_size) - bz) <= box.half[2]]
    column = _linear(ci[ii], cj[jj], np.zeros_like(ii), shape)
    return (column[:, None] + kk[None, :]).ravel()


def _blob_cells(
    boxes: tuple[_Box, ...],
    origin: FloatArray,
    yaw: float,
    voxel_size: float,
    shape: tuple[int, int, int],
) -> IntArray:
    """Linear indices (possibly repeated) of a blob's cells."""
    return np.concatenate([_box_cells(b, origin, yaw, voxel_size, shape) for b in boxes])


def _static_cells(config: VoxelSceneConfig, shape: tuple[int, int, int]) -> IntArray:
    """Linear indices (possibly repeated) of all spurious blobs' cells."""
    parts = [
        _blob_cells(b, c, yaw, config.voxel_size, shape) for _, b, c, yaw in _placed_blobs(config)
    ]
    return np.concatenate(parts) if parts else np.zeros(0, np.int64)


def _placed_blobs(
    config: VoxelSceneConfig,
) -> list[tuple[str, tuple[_Box, ...], FloatArray, float]]:
    """(kind, boxes, footprint centre, yaw) of each spurious blob: kinds in _BLOB_KINDS order,
    footprints away from the walls, from one another and from everyone's path (people walk
    around furniture; each placement depends only on the earlier ones and the paths)."""
    rng = np.random.default_rng(_streams(config.seed)[1])
    paths = _plan(_people_key(config)).xy.reshape(-1, 2)
    placed: list[tuple[str, tuple[_Box, ...], FloatArray, float]] = []
    footprints: list[tuple[FloatArray, float]] = []
    for n in range(config.spurious):
        kind, radius, boxes = _BLOB_KINDS[n % len(_BLOB_KINDS)]
        centre = _free_spot(radius, footprints, paths, rng)
        footprints.append((centre, radius))
        placed.append((kind, boxes, centre, rng.uniform(0.0, 2.0 * math.pi)))
    return placed


def _free_spot(
    radius: float,
    taken: list[tuple[FloatArray, float]],
    paths: FloatArray,
    rng: np.random.Generator,
) -> FloatArray:
    """A footprint centre BLOB_WALL_CLEARANCE_M from the walls, 0.3 m clear of ``taken`` and
    PATH_CLEARANCE_M clear of every point of ``paths`` (P, 2) (of 200 draws clear of ``taken``,
    the one farthest from the paths when none is clear of them)."""
    lo, hi = _walk_box(BLOB_WALL_CLEARANCE_M + radius)
    best, best_gap = rng.uniform(lo, hi), -np.inf
    for _ in range(200):
        centre = rng.uniform(lo, hi)
        if any(np.linalg.norm(centre - c) < radius + r + 0.3 for c, r in taken):
            continue
        gap = float(np.min(np.linalg.norm(paths - centre, axis=1))) - radius if len(paths) else 0
        if gap > best_gap:
            best, best_gap = centre, gap
        if gap >= PATH_CLEARANCE_M:
            break
    return best
