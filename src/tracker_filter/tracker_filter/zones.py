"""Zones of the scene, as Frigate's: polygons in scene px (no rclpy).

- **Ignore zones**: a detection whose foot point (the bottom centre of its box, where a person
  stands) lies in one is not a measurement: a flag, a tree, a road whose cars are not wanted.
- **Required zones**: with any given, the camera follows a track (automatic selection) only once
  its foot point has been in one of them (Frigate's `required_zones`): only the people who came
  through the gate, not every passer-by. Manual selection takes any track.

A polygon is written as Frigate writes a zone's coordinates, "x1,y1,x2,y2,x3,y3,..." (at least
three points); several are separated by ";".
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tracker_filter.observation import Detections
from tracker_filter.tracking import TrackSet, TrackStatus


@dataclass(frozen=True, eq=False)
class Polygon:
    """A simple polygon (N, 2) in scene px."""

    points: np.ndarray

    def contains(self, xy: np.ndarray) -> np.ndarray:
        """Which of the points (M, 2) lie inside (even-odd rule; a point on an edge may fall
        either way)."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        inside = np.zeros(len(xy), dtype=bool)
        x, y = xy[:, 0], xy[:, 1]
        for (x1, y1), (x2, y2) in zip(self.points, np.roll(self.points, -1, axis=0), strict=True):
            crosses = (y1 > y) != (y2 > y)
            with np.errstate(divide="ignore", invalid="ignore"):
                edge_x = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
            inside ^= crosses & (x < edge_x)
        return inside


def parse_polygons(text: str, name: str = "zones") -> tuple[Polygon, ...]:
    """The polygons of "x1,y1,x2,y2,x3,y3; ..." ('' = none); raises ValueError naming `name`."""
    polygons = []
    for number, part in enumerate((p for p in text.split(";") if p.strip()), start=1):
        try:
            values = [float(v) for v in part.replace(" ", "").split(",") if v]
        except ValueError as error:
            raise ValueError(
                f"{name}: polygon {number} is not numbers: '{part.strip()}'"
            ) from error
        if len(values) % 2 or len(values) < 6 or not np.all(np.isfinite(values)):
            raise ValueError(
                f"{name}: polygon {number} needs at least three finite x,y points, got "
                f"'{part.strip()}'"
            )
        polygons.append(Polygon(np.array(values).reshape(-1, 2)))
    return tuple(polygons)


def foot_points(bboxes: np.ndarray) -> np.ndarray:
    """The bottom centres (M, 2) of boxes (M, 4) given as x, y, width, height."""
    boxes = np.asarray(bboxes, dtype=float).reshape(-1, 4)
    return np.column_stack([boxes[:, 0] + boxes[:, 2] / 2.0, boxes[:, 1] + boxes[:, 3]])


def _in_any(polygons: tuple[Polygon, ...], points: np.ndarray) -> np.ndarray:
    inside = np.zeros(len(points), dtype=bool)
    for polygon in polygons:
        inside |= polygon.contains(points)
    return inside


@dataclass
class Zones:
    """The ignore and required zones, and which tracks have been in a required one."""

    ignore: tuple[Polygon, ...] = ()
    required: tuple[Polygon, ...] = ()
    entered: set[int] = field(default_factory=set)  # ids of tracks seen in a required zone

    def outside_ignored(self, detections: Detections) -> tuple[Detections, int]:
        """The detections whose foot point is in no ignore zone, and how many were dropped."""
        if not self.ignore or not len(detections):
            return detections, 0
        ignored = _in_any(self.ignore, foot_points(detections.bboxes))
        return detections.subset(np.flatnonzero(~ignored)), int(ignored.sum())

    def followable(self, tracks: TrackSet) -> np.ndarray | None:
        """Which tracks may be followed automatically (None: every one, no required zone): those
        seen in a required zone, now or before. Call once per frame."""
        if not self.required:
            return None
        live = tracks.status != TrackStatus.LOST
        inside = _in_any(self.required, foot_points(tracks.bboxes)) & live
        self.entered.update(int(i) for i in tracks.ids[inside])
        self.entered.intersection_update(int(i) for i in tracks.ids[live])  # forget the gone
        return np.array([int(i) in self.entered for i in tracks.ids], dtype=bool)

    def describe(self) -> str:
        """'; 1 ignore zone(s), 2 required zone(s)' ('' without zones), for a log line."""
        counts = [(len(self.ignore), "ignore"), (len(self.required), "required")]
        parts = [f"{n} {kind} zone(s)" for n, kind in counts if n]
        return "; " + ", ".join(parts) if parts else ""

    def reset(self) -> None:
        self.entered.clear()
