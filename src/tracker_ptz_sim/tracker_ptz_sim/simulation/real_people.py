"""Real people cut out of an annotated clip, to walk the street scenes' paths (no rclpy).

A :class:`CutoutLibrary` holds, per annotated person of a real clip (vtest.avi and its reviewed
ground truth), runs of consecutive frames in which that person is seen whole and alone: inside the
frame, no other annotated box touching theirs, at least ``min_height`` px tall. Each frame of a
run is a sprite: the colour pixels around the person and a mask, the pixels that differ from the
clip's background (its per-pixel median) by more than ``threshold`` grey levels, closed, holes
filled, kept inside the person's box, the part connected to the middle of the box only. A run
keeps the gait as it was filmed; its foot and height come from the ground-truth box.

The people are split into a development set and a held-out set (:func:`split`: every third person
by id, in the order of their ids, is held out), so scenes of held-out people are never seen while
tuning. The street generator (``simulation.street``, ``people`` = "development" or "held_out")
pastes a run's frames along a person's path: scaled to the path's perspective height, mirrored to
walk the path's way, advanced by the distance walked (``RealLook.phase``: a source frame per
``cycle`` metres, so the legs move at the speed the person was filmed at), holding the frame while
the person stands. The pasted mask is the ground truth (``label``), so the boxes are exact.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from tracker_ptz_sim.simulation.frame_sources import video_frames
from tracker_ptz_sim.simulation.ground_truth import Box, Tracks, read_tracks

SETS = ("development", "held_out")


@dataclass(frozen=True)
class CutoutConfig:
    min_height: float = 45.0  # px: smaller people are too coarse to scale up
    min_run: int = 12  # frames: shorter runs show too little of a gait
    margin: float = 4.0  # px between a person's box and any other person's and the frame edge
    threshold: float = 28.0  # grey levels of difference from the background that are the person
    min_fill: float = 0.35  # a mask filling less of its box than this is a bad cut-out ...
    max_fill: float = 0.9  # ... and one filling more (the background changed, a shadow) too


@dataclass(frozen=True, eq=False)
class Sprite:
    """One frame of a person: BGR pixels, a float alpha in [0, 1], the foot point and height."""

    colour: np.ndarray  # (h, w, 3) uint8
    alpha: np.ndarray  # (h, w) float32
    foot: tuple[float, float]  # px in the sprite: the box's bottom centre
    height: float  # px: the person's box height


@dataclass(frozen=True, eq=False)
class Run:
    """Consecutive frames of one person, seen whole and alone."""

    person: int  # the annotated id
    first_frame: int  # from 1
    sprites: list[Sprite]
    direction: float  # +1 walking right in the image, -1 left
    stride: float  # statures walked per frame (the foot's image motion / the height)


@dataclass
class CutoutLibrary:
    runs: list[Run]

    def people(self) -> list[int]:
        return sorted({r.person for r in self.runs})

    def of_set(self, name: str) -> list[Run]:
        """The runs of the development or the held-out people."""
        chosen = split(self.people())[name]
        return [r for r in self.runs if r.person in chosen]


def split(people: list[int]) -> dict[str, set[int]]:
    """Development and held-out people: every third id (in id order) is held out."""
    ordered = sorted(people)
    held = {p for k, p in enumerate(ordered) if k % 3 == 2}
    return {"development": set(ordered) - held, "held_out": held}


def _alone(frame_boxes: dict[int, Box], ident: int, width: int, height: int, margin: float) -> bool:
    b = frame_boxes[ident]
    if b.x < margin or b.y < margin or b.x + b.w > width - margin or b.y + b.h > height - margin:
        return False
    for other, o in frame_boxes.items():
        if other == ident:
            continue
        apart = (
            o.x > b.x + b.w + margin
            or b.x > o.x + o.w + margin
            or o.y > b.y + b.h + margin
            or b.y > o.y + o.h + margin
        )
        if not apart:
            return False
    return True


def cut_out(
    frame: np.ndarray, background: np.ndarray, box: Box, config: CutoutConfig
) -> Sprite | None:
    """The person in `box` of `frame` as a sprite (None: the mask does not look like a person)."""
    H, W = frame.shape[:2]
    pad_x, pad_y = 0.15 * box.w + 2, 0.04 * box.h + 2
    x0, y0 = max(0, math.floor(box.x - pad_x)), max(0, math.floor(box.y - pad_y))
    x1 = min(W, math.ceil(box.x + box.w + pad_x))
    y1 = min(H, math.ceil(box.y + box.h + pad_y))
    crop, ground = frame[y0:y1, x0:x1], background[y0:y1, x0:x1]
    difference = cv2.absdiff(cv2.GaussianBlur(crop, (3, 3), 0), cv2.GaussianBlur(ground, (3, 3), 0))
    mask = (difference.max(axis=2) > config.threshold).astype(np.uint8)
    inside = np.zeros_like(mask)
    bx0, by0 = round(box.x) - x0, round(box.y) - y0
    bx1, by1 = round(box.x + box.w) - x0, round(box.y + box.h) - y0
    inside[max(by0, 0) : by1, max(bx0, 0) : bx1] = 1
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5))
    mask = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, kernel) & inside
    mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, np.ones((2, 2), np.uint8))
    mask = _fill_holes(mask)
    mask = _middle_part(mask, (bx0 + bx1) / 2, (by0 + by1) / 2, box.h)
    fill = float(mask.sum()) / max(box.w * box.h, 1.0)
    if mask.sum() == 0 or not config.min_fill <= fill <= config.max_fill:
        return None
    alpha = cv2.GaussianBlur(mask.astype(np.float32), (3, 3), 0.7) * inside
    foot = (box.x + box.w / 2 - x0, box.y + box.h - y0)
    return Sprite(crop.copy(), alpha.astype(np.float32), foot, box.h)


def _fill_holes(mask: np.ndarray) -> np.ndarray:
    """The mask with every background region not connected to its border filled."""
    padded = np.pad(mask, 1)
    flood = padded.copy()
    cv2.floodFill(flood, None, (0, 0), 1)
    holes = (flood == 0)[1:-1, 1:-1]
    filled: np.ndarray = mask | holes.astype(np.uint8)
    return filled


def _middle_part(mask: np.ndarray, cx: float, cy: float, height: float) -> np.ndarray:
    """The connected parts of the mask that reach into the box's middle third of its height."""
    count, labels = cv2.connectedComponents(mask, connectivity=8)
    keep = np.zeros_like(mask)
    rows = slice(max(0, round(cy - height / 6)), round(cy + height / 6))
    cols = slice(max(0, round(cx - height / 12)), round(cx + height / 12) + 1)
    for label in set(np.unique(labels[rows, cols]).tolist()) - {0}:
        keep[labels == label] = 1
    return keep if count > 1 else mask


def build_library(
    frames: Iterable[np.ndarray], background: np.ndarray, truth: Tracks, config: CutoutConfig
) -> CutoutLibrary:
    """Every run of every annotated person of the clip (see the module docstring)."""
    H, W = background.shape[:2]
    good: dict[int, dict[int, Sprite]] = {ident: {} for ident in truth.ids()}
    for index, frame in enumerate(frames):
        f = index + 1
        present = truth.in_frame(f)
        for ident, box in present.items():
            if box.h < config.min_height or not _alone(present, ident, W, H, config.margin):
                continue
            sprite = cut_out(frame, background, box, config)
            if sprite is not None:
                good[ident][f] = sprite
    runs: list[Run] = []
    for ident, sprites in good.items():
        boxes = truth.by_id[ident]
        for start, length in _consecutive(sorted(sprites)):
            if length < config.min_run:
                continue
            span = range(start, start + length)
            feet = np.array([[boxes[f].x + boxes[f].w / 2, boxes[f].y + boxes[f].h] for f in span])
            heights = np.array([boxes[f].h for f in span])
            moved = feet[-1] - feet[0]
            stride = float(np.hypot(*np.diff(feet, axis=0).T).mean() / heights.mean())
            direction = 1.0 if moved[0] >= 0 else -1.0
            runs.append(Run(ident, start, [sprites[f] for f in span], direction, stride))
    return CutoutLibrary(runs)


def _consecutive(frames: list[int]) -> list[tuple[int, int]]:
    """(start, length) of each stretch of consecutive frame numbers."""
    out: list[tuple[int, int]] = []
    for f in frames:
        if out and out[-1][0] + out[-1][1] == f:
            out[-1] = (out[-1][0], out[-1][1] + 1)
        else:
            out.append((f, 1))
    return out


def load_library(
    video: Path, gt: Path, background: np.ndarray, config: CutoutConfig
) -> CutoutLibrary:
    """The library of `video` and its ground truth file `gt`."""
    return build_library(video_frames(video), background, read_tracks(gt), config)


@dataclass(frozen=True, eq=False)
class RealLook:
    """A street person's look: a run of a real person (see the module docstring)."""

    run: Run
    phase: float  # source frame at the path's start
    cycle: float  # m walked per source frame (the person's stride x stature)


class LookChooser:
    """Real looks for one scene's people: each a person not used yet in the scene while there are
    any (then again from all), a random run of theirs, a random frame of it to start at."""

    def __init__(self, rng: np.random.Generator, runs: list[Run]) -> None:
        if not runs:
            raise ValueError("no cut-out runs to dress people in")
        self.rng = rng
        self.runs = runs
        self.unused = sorted({r.person for r in runs})

    def look(self, stature: float) -> RealLook:
        if not self.unused:
            self.unused = sorted({r.person for r in self.runs})
        person = self.unused.pop(int(self.rng.integers(len(self.unused))))
        theirs = [r for r in self.runs if r.person == person]
        run = theirs[int(self.rng.integers(len(theirs)))]
        start = float(self.rng.uniform(0, len(run.sprites)))
        return RealLook(run, start, max(run.stride, 0.005) * stature)


def real_sprite(
    look: RealLook, phase: float, foot: tuple[float, float], height: float, rightwards: bool
) -> tuple[np.ndarray, np.ndarray, int, int]:
    """The run's frame at `phase` scaled to `height` px with its foot at `foot` (image px),
    mirrored when it walks the other way: BGR float32 pixels, alpha, and the top-left corner."""
    sprites = look.run.sprites
    sprite = sprites[int(math.floor(phase)) % len(sprites)]
    scale = height / sprite.height
    h, w = sprite.alpha.shape
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    shrink = scale < 1
    method = cv2.INTER_AREA if shrink else cv2.INTER_LINEAR
    colour = cv2.resize(sprite.colour, size, interpolation=method).astype(np.float32)
    alpha = cv2.resize(sprite.alpha, size, interpolation=cv2.INTER_LINEAR)
    fx = sprite.foot[0] * size[0] / w
    if (look.run.direction > 0) != rightwards:
        colour, alpha, fx = colour[:, ::-1], alpha[:, ::-1], size[0] - fx
    x0 = round(foot[0] - fx)
    y0 = round(foot[1] - sprite.foot[1] * size[1] / h)
    return np.ascontiguousarray(colour), np.ascontiguousarray(alpha), x0, y0
