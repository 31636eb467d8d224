"""Pinhole camera images and the scene's equiangular grid (no rclpy).

The suite's scene is equiangular: scene x = cx - f * pan, y = cy + f * tilt (f: scene px per rad),
and a `View` maps image pixels to scene pixels linearly. A real camera is a pinhole: pixel u looks
along pan - atan((u - cx) / fx) (`camera_pixel_to_angles`: pan and tilt independent, principal
point at the image centre), so its image is not a linear window of the scene. At a 60 degree field
of view a pixel halfway to the edge of a 640 px wide image lies 11 px from where the window of the
edge rays (`view_from_pan_tilt`) puts it, 3.5 px at 34 degrees: a panning camera's background then
misregisters by that much and leaves ghosts. `to_equiangular` resamples a pinhole image onto the
linear grid of that window, after which the linear View is exact; `pinhole_view` renders the
pinhole image of a window of the scene (the simulator standing in for a real camera).

Pixel centres are at integer coordinates (cv2.remap); an axis of n pixels spans [-0.5, n - 0.5].
"""

from __future__ import annotations

import math
from functools import lru_cache

import cv2
import numpy as np

MAX_HALF_ANGLE = 1.5  # rad: a pinhole camera's field of view stays below 180 degrees


def pinhole_focal(pixels: int, span: float, focal: float) -> float:
    """The pinhole focal length [px] of an image axis of `pixels` whose edge rays span `span`
    scene px of an equiangular scene with `focal` scene px per rad."""
    return pixels / 2.0 / math.tan(min(span / 2.0 / focal, MAX_HALF_ANGLE))


def _pinhole_of_equiangular(pixels: int, span: float, focal: float) -> np.ndarray:
    """Per pixel of an equiangular axis spanning `span`, where it lies on the pinhole axis."""
    offsets = (np.arange(pixels) + 0.5) * (span / pixels) - span / 2.0  # scene px from the axis
    fx = pinhole_focal(pixels, span, focal)
    positions: np.ndarray = (pixels / 2.0 + fx * np.tan(offsets / focal) - 0.5).astype(np.float32)
    return positions


def _equiangular_of_pinhole(pixels: int, span: float, focal: float) -> np.ndarray:
    """Per pixel of a pinhole axis whose edge rays span `span`, its scene offset from the span's
    start (the inverse of `_pinhole_of_equiangular`)."""
    fx = pinhole_focal(pixels, span, focal)
    angles = np.arctan((np.arange(pixels) + 0.5 - pixels / 2.0) / fx)
    offsets: np.ndarray = (span / 2.0 + focal * angles - 0.5).astype(np.float32)
    return offsets


@lru_cache(maxsize=8)
def _maps(
    width: int,
    height: int,
    span_x: float,
    span_y: float,
    focal: float,
    inverse: bool,
    offset: tuple[float, float] = (0.0, 0.0),
) -> tuple[np.ndarray, np.ndarray]:
    """cv2.remap's maps (cached: they change only with the zoom), shifted by `offset` (x, y)."""
    axis = _equiangular_of_pinhole if inverse else _pinhole_of_equiangular
    map_x = np.broadcast_to(axis(width, span_x, focal) + np.float32(offset[0]), (height, width))
    column = axis(height, span_y, focal) + np.float32(offset[1])
    map_y = np.broadcast_to(column[:, None], (height, width))
    return np.ascontiguousarray(map_x), np.ascontiguousarray(map_y)


def to_equiangular(pixels: np.ndarray, span: tuple[float, float], focal: float) -> np.ndarray:
    """The pinhole image `pixels` resampled onto the linear grid of the scene window its edge
    rays span (`span`: the window's width and height, scene px), same size."""
    height, width = pixels.shape[:2]
    map_x, map_y = _maps(width, height, float(span[0]), float(span[1]), float(focal), False)
    return cv2.remap(pixels, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)


def pinhole_view(
    region: np.ndarray, size: tuple[int, int], span: tuple[float, float], focal: float
) -> np.ndarray:
    """The `size` (width, height) pinhole image whose edge rays span `span` scene px, centred
    on `region` (scene pixels, as large as the span or larger, centred the same)."""
    width, height = size
    margins = ((region.shape[1] - span[0]) / 2.0, (region.shape[0] - span[1]) / 2.0)
    map_x, map_y = _maps(width, height, float(span[0]), float(span[1]), float(focal), True, margins)
    return cv2.remap(region, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
