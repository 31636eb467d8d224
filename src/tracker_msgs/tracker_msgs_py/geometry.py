"""Scene / pan-tilt geometry shared by every package (no rclpy).

The tracker's world frame is the *scene frame*: pixels of a fixed virtual image of the whole
surveillance area. In simulation it is the recorded frame itself; on a real pan-tilt unit it is the
line of sight's pan/tilt angles scaled by a fixed focal length, so the same tracker parameters (in
pixels) serve both. Angles follow REP-103 about the pan-tilt base: pan about +z (positive = left),
tilt about +y (positive = down); pan = tilt = 0 looks at the scene centre:

    x = cx - f * pan        y = cy + f * tilt          (f in scene px per radian)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Rect:
    """Axis-aligned rectangle in pixels (x right, y down, origin at the top-left pixel corner)."""

    x: float
    y: float
    width: float
    height: float

    @property
    def center(self) -> tuple[float, float]:
        return (self.x + self.width / 2.0, self.y + self.height / 2.0)

    @property
    def area(self) -> float:
        return max(self.width, 0.0) * max(self.height, 0.0)

    @classmethod
    def from_center(cls, cx: float, cy: float, width: float, height: float) -> Rect:
        return cls(cx - width / 2.0, cy - height / 2.0, width, height)

    def intersection(self, other: Rect) -> Rect | None:
        """The overlap of two rectangles, or None when they do not overlap."""
        x0, y0 = max(self.x, other.x), max(self.y, other.y)
        x1 = min(self.x + self.width, other.x + other.width)
        y1 = min(self.y + self.height, other.y + other.height)
        if x1 <= x0 or y1 <= y0:
            return None
        return Rect(x0, y0, x1 - x0, y1 - y0)

    def intersection_area(self, other: Rect) -> float:
        """The area of the overlap of two rectangles, 0 when they do not overlap."""
        inter = self.intersection(other)
        return 0.0 if inter is None else inter.area

    def iou(self, other: Rect) -> float:
        """Intersection over union, 0 when disjoint."""
        inter = self.intersection(other)
        if inter is None:
            return 0.0
        return inter.area / (self.area + other.area - inter.area)

    def contains(self, x: float, y: float) -> bool:
        return self.x <= x < self.x + self.width and self.y <= y < self.y + self.height


def intersection_areas(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Areas (N, M) of the overlaps of (N, 4) and (M, 4) x, y, width, height boxes (0: disjoint)."""
    a = np.asarray(a, dtype=float)[:, None, :]
    b = np.asarray(b, dtype=float)[None, :, :]
    width = np.minimum(a[..., 0] + a[..., 2], b[..., 0] + b[..., 2]) - np.maximum(
        a[..., 0], b[..., 0]
    )
    height = np.minimum(a[..., 1] + a[..., 3], b[..., 1] + b[..., 3]) - np.maximum(
        a[..., 1], b[..., 1]
    )
    areas: np.ndarray = np.clip(width, 0, None) * np.clip(height, 0, None)
    return areas


def iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Intersection over union (N, M) of (N, 4) and (M, 4) x, y, width, height boxes (0 where
    both are empty)."""
    a = np.asarray(a, dtype=float).reshape(-1, 4)
    b = np.asarray(b, dtype=float).reshape(-1, 4)
    inter = intersection_areas(a, b)
    union = (a[:, 2] * a[:, 3])[:, None] + (b[:, 2] * b[:, 3])[None, :] - inter
    result: np.ndarray = np.divide(inter, union, out=np.zeros_like(inter), where=union > 0)
    return result


def _corners(boxes: np.ndarray) -> np.ndarray:
    boxes = np.asarray(boxes, dtype=float)
    return boxes.reshape(len(boxes), -1)[:, :4] if boxes.size else np.zeros((len(boxes), 4))


def corner_iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """`iou_matrix` of boxes given by their corners (x0, y0, x1, y1, any further columns)."""
    a, b = _corners(a), _corners(b)
    return iou_matrix(
        np.column_stack([a[:, :2], a[:, 2:] - a[:, :2]]),
        np.column_stack([b[:, :2], b[:, 2:] - b[:, :2]]),
    )


@dataclass(frozen=True)
class SceneGeometry:
    """Linear (equiangular) mapping between pan/tilt angles and scene pixels."""

    width: int  # scene width, px
    height: int  # scene height, px
    focal_length: float  # scene px per radian

    def __post_init__(self) -> None:
        if self.width <= 0 or self.height <= 0:
            raise ValueError(f"scene size must be positive, got {self.width}x{self.height}")
        if not math.isfinite(self.focal_length) or self.focal_length <= 0.0:
            raise ValueError(f"focal_length must be a positive number, got {self.focal_length}")

    @property
    def center(self) -> tuple[float, float]:
        return (self.width / 2.0, self.height / 2.0)

    def angles_to_pixel(self, pan: float, tilt: float) -> tuple[float, float]:
        """Scene pixel (x, y) the line of sight (pan, tilt) [rad] points at."""
        cx, cy = self.center
        return (cx - self.focal_length * pan, cy + self.focal_length * tilt)

    def pixel_to_angles(self, x: float, y: float) -> tuple[float, float]:
        """Pan/tilt [rad] that point the line of sight at scene pixel (x, y)."""
        cx, cy = self.center
        return ((cx - x) / self.focal_length, (y - cy) / self.focal_length)

    def rate_to_pixel_velocity(self, pan_rate: float, tilt_rate: float) -> tuple[float, float]:
        """Scene-pixel velocity [px/s] of the view centre for angular rates [rad/s]."""
        return (-self.focal_length * pan_rate, self.focal_length * tilt_rate)

    def pixel_velocity_to_rate(self, vx: float, vy: float) -> tuple[float, float]:
        """Angular rates [rad/s] that move the view centre at (vx, vy) scene px/s."""
        return (-vx / self.focal_length, vy / self.focal_length)


def camera_pixel_to_angles(
    u: float, v: float, pan: float, tilt: float, fx: float, fy: float, cx: float, cy: float
) -> tuple[float, float]:
    """Pan/tilt [rad] of the ray through camera pixel (u, v) of a real pinhole camera.

    (pan, tilt) is the camera's line of sight (its optical axis), (fx, fy, cx, cy) its intrinsics
    from CameraInfo.K. Pan and tilt are treated as independent (exact on the horizon line, a
    second-order error elsewhere), which is what a pan-tilt tracker needs for aiming.
    """
    return (pan - math.atan2(u - cx, fx), tilt + math.atan2(v - cy, fy))
