"""The review's corrections to the assistant's tracks: a small YAML file the tool applies (no rclpy).

A list of fixes, applied in order; frames are numbered from 1 (as in gt.txt), boxes are
`[x, y, w, h]` in px, every fix may say `why`:

    - delete: {id: 12, why: the sign on the post at the top left}      # a whole track
    - delete: {id: 5, frames: [100, 120]}                 # its boxes in frames 100..120
    - add: {id: 40, boxes: {300: [x, y, w, h], 330: [x, y, w, h]}}
          # a person the assistant missed: keyframes, filled in between by the interpolation
          # (gaps up to linking.LinkConfig.max_gap frames); an existing id gets the boxes added
    - move: {id: 7, boxes: {210: [x, y, w, h]}}           # a box in the wrong place
    - join: {ids: [5, 12]}                                # one person: 12's boxes become 5's
    - split: {id: 5, frame: 300, new_id: 41}              # from frame 300 on, 5 is another person
    - swap: {ids: [3, 4], frame: 250}                     # from 250 on the two ids are exchanged
    - path: {id: 3, boxes: {25: [x, y, w, h], 40: [...], 55: [...]}}
          # where a person really is over frames 25..55, for a stretch the assistant got wrong
          # (people crowding, merged boxes): keyframes read off the review's strips, each frame
          # in between interpolated and then snapped to the assistant's own box that overlaps it
          # best (IoU >= SNAP_IOU, a height within 25 %), which is tighter than a line between
          # keyframes; the id's other boxes in the span go

`apply` counts what the review changed (boxes added, removed and moved; id fixes) for the
annotation's README, and refuses a fix that names an id or box that is not there (a stale
corrections file is one clear error, not a silently different ground truth).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from tracker_msgs_py.geometry import corner_iou_matrix
from tracker_ptz_sim.annotation.linking import interpolate
from tracker_ptz_sim.simulation.ground_truth import Box, Detections, Tracks

KINDS = ("delete", "add", "move", "join", "split", "swap", "path")
SNAP_IOU = 0.5


class CorrectionError(ValueError):
    """A fix that cannot be applied (names the fix by its position and kind)."""


@dataclass(frozen=True)
class Fix:
    kind: str
    args: dict[str, Any]
    index: int  # position in the file, from 1

    def where(self) -> str:
        why = self.args.get("why")
        return f"fix {self.index} ({self.kind}{': ' + why if why else ''})"

    def number(self, name: str) -> int:
        """The whole number `name` of this fix (an id or a frame, >= 1)."""
        value = self.args.get(name)
        if not isinstance(value, int) or isinstance(value, bool) or value < 1:
            raise CorrectionError(
                f"{self.where()}: {name} must be a whole number >= 1, got {value!r}"
            )
        return value

    def numbers(self, name: str, count: int | None = None) -> list[int]:
        """The list of whole numbers `name` (`count` of them when given)."""
        values = self.args.get(name)
        if not isinstance(values, list) or not all(isinstance(v, int) and v >= 1 for v in values):
            values = None
        if values is None or (count is not None and len(values) != count):
            wanted = f"{count} " if count else ""
            raise CorrectionError(f"{self.where()}: {name} must be a list of {wanted}whole numbers")
        return list(values)

    def boxes(self) -> dict[int, Box]:
        """The fix's `boxes`: frame -> box."""
        values = self.args.get("boxes")
        if not isinstance(values, dict) or not values:
            raise CorrectionError(f"{self.where()}: boxes must map frames to [x, y, w, h]")
        return {int(frame): _box(value, self) for frame, value in sorted(values.items())}


@dataclass
class Applied:
    tracks: Tracks
    detections: Detections = field(default_factory=Detections)  # the assistant's, for `path`
    counts: Counter = field(default_factory=Counter)

    def summary(self) -> str:
        c = self.counts
        return (
            f"{c['boxes added']} boxes added, {c['boxes removed']} removed, {c['boxes moved']} "
            f"moved; {c['tracks deleted']} tracks deleted; {c['id fixes']} id fixes "
            f"({c['join']} joins, {c['split']} splits, {c['swap']} swaps); {c['path']} paths "
            f"traced ({c['boxes snapped']} of their boxes snapped to the assistant's)"
        )


def parse(text: str) -> list[Fix]:
    items = yaml.safe_load(text) or []
    if not isinstance(items, list):
        raise CorrectionError("the corrections file must be a list of fixes")
    fixes = []
    for index, item in enumerate(items, 1):
        if not isinstance(item, dict) or len(item) != 1:
            raise CorrectionError(f"fix {index} must be one of {', '.join(KINDS)}: {item!r}")
        ((kind, args),) = item.items()
        if kind not in KINDS or not isinstance(args, dict):
            raise CorrectionError(f"fix {index} must be one of {', '.join(KINDS)}: {item!r}")
        fixes.append(Fix(kind, args, index))
    return fixes


def load(path: Path) -> list[Fix]:
    return parse(path.read_text())


def _box(value: Any, fix: Fix) -> Box:
    if not (isinstance(value, list) and len(value) == 4) or value[2] <= 0 or value[3] <= 0:
        raise CorrectionError(f"{fix.where()}: a box is [x, y, w, h] with w, h > 0, got {value}")
    x, y, w, h = (float(v) for v in value)
    return Box(x, y, w, h)


def _track(tracks: Tracks, ident: int, fix: Fix) -> dict[int, Box]:
    if ident not in tracks.by_id:
        raise CorrectionError(f"{fix.where()}: there is no id {ident}")
    return tracks.by_id[ident]


def apply(tracks: Tracks, fixes: list[Fix], detections: Detections | None = None) -> Applied:
    """The tracks after every fix, and what the fixes changed (see the module docstring);
    `detections` are the assistant's boxes `path` snaps to."""
    out = Applied(tracks.copy(), detections or Detections())
    for fix in fixes:
        _APPLY[fix.kind](out, fix)
    return out


def _delete(out: Applied, fix: Fix) -> None:
    ident = fix.number("id")
    boxes = _track(out.tracks, ident, fix)
    if "frames" not in fix.args:
        out.counts["boxes removed"] += len(boxes)
        out.counts["tracks deleted"] += 1
        del out.tracks.by_id[ident]
        return
    first, last = fix.numbers("frames", 2)
    gone = [f for f in boxes if first <= f <= last]
    if not gone:
        raise CorrectionError(f"{fix.where()}: id {ident} has no box in frames {first}-{last}")
    for f in gone:
        del boxes[f]
    out.counts["boxes removed"] += len(gone)
    if not boxes:
        del out.tracks.by_id[ident]


def _add(out: Applied, fix: Fix) -> None:
    ident = fix.number("id")
    boxes = out.tracks.by_id.setdefault(ident, {})
    for frame, box in fix.boxes().items():
        if frame in boxes:
            raise CorrectionError(f"{fix.where()}: id {ident} already has a box in {frame}")
        boxes[frame] = box
        out.counts["boxes added"] += 1
    out.tracks.by_id[ident] = dict(sorted(boxes.items()))


def _move(out: Applied, fix: Fix) -> None:
    ident = fix.number("id")
    boxes = _track(out.tracks, ident, fix)
    for frame, box in fix.boxes().items():
        if frame not in boxes:
            raise CorrectionError(f"{fix.where()}: id {ident} has no box in frame {frame}")
        boxes[frame] = box
        out.counts["boxes moved"] += 1


def _join(out: Applied, fix: Fix) -> None:
    keep, *others = fix.numbers("ids")
    if not others:
        raise CorrectionError(f"{fix.where()}: join needs two ids or more")
    target = _track(out.tracks, keep, fix)
    for other in others:
        boxes = _track(out.tracks, other, fix)
        both = sorted(set(target) & set(boxes))
        if both:
            raise CorrectionError(f"{fix.where()}: ids {keep} and {other} share frames {both[:5]}")
        target.update(boxes)
        del out.tracks.by_id[other]
    out.tracks.by_id[keep] = dict(sorted(target.items()))
    out.counts["join"] += 1
    out.counts["id fixes"] += 1


def _split(out: Applied, fix: Fix) -> None:
    ident, frame, new_id = fix.number("id"), fix.number("frame"), fix.number("new_id")
    boxes = _track(out.tracks, ident, fix)
    if new_id in out.tracks.by_id:
        raise CorrectionError(f"{fix.where()}: id {new_id} is taken")
    later = {f: b for f, b in boxes.items() if f >= frame}
    if not later or len(later) == len(boxes):
        raise CorrectionError(f"{fix.where()}: id {ident} has no boxes on both sides of {frame}")
    for f in later:
        del boxes[f]
    out.tracks.by_id[new_id] = later
    out.counts["split"] += 1
    out.counts["id fixes"] += 1


def _swap(out: Applied, fix: Fix) -> None:
    a, b = fix.numbers("ids", 2)
    frame = fix.number("frame")
    first, second = _track(out.tracks, a, fix), _track(out.tracks, b, fix)
    later_a = {f: x for f, x in first.items() if f >= frame}
    later_b = {f: x for f, x in second.items() if f >= frame}
    for f in later_a:
        del first[f]
    for f in later_b:
        del second[f]
    first.update(later_b)
    second.update(later_a)
    out.tracks.by_id[a] = dict(sorted(first.items()))
    out.tracks.by_id[b] = dict(sorted(second.items()))
    out.counts["swap"] += 1
    out.counts["id fixes"] += 1


def snapped(box: Box, candidates: list[Box]) -> Box | None:
    """The candidate that overlaps `box` best, when by IoU >= SNAP_IOU with a height within 25 %."""
    if not candidates:
        return None
    overlap = corner_iou_matrix(box.corners[None], np.array([c.corners for c in candidates]))[0]
    best = int(np.argmax(overlap))
    ratio = candidates[best].h / box.h
    if overlap[best] < SNAP_IOU or not 0.8 <= ratio <= 1.25:
        return None
    c = candidates[best]
    return Box(c.x, c.y, c.w, c.h)


def _path(out: Applied, fix: Fix) -> None:
    ident = fix.number("id")
    keys = fix.boxes()
    first, last = min(keys), max(keys)
    if len(keys) < 2:
        raise CorrectionError(f"{fix.where()}: a path needs two keyframes or more")
    snap = fix.args.get("snap", True)
    if not isinstance(snap, bool):
        raise CorrectionError(f"{fix.where()}: snap must be true or false")
    boxes = out.tracks.by_id.setdefault(ident, {})
    for frame, box in interpolate(keys, max_gap=last - first).items():
        near = snapped(box, out.detections.by_frame.get(frame, [])) if snap else None
        out.counts["boxes moved" if frame in boxes else "boxes added"] += 1
        out.counts["boxes snapped"] += near is not None
        boxes[frame] = near or box  # an interpolated box keeps score 0: drawn thin
    out.tracks.by_id[ident] = dict(sorted(boxes.items()))
    out.counts["path"] += 1


_APPLY = {
    "delete": _delete,
    "add": _add,
    "move": _move,
    "join": _join,
    "split": _split,
    "swap": _swap,
    "path": _path,
}
