"""What a camera does to a rendered scene frame, shared by the scene generators (no rclpy): the
lighting's drift, lens blur, sensor noise and JPEG compression, a given background fitted to the
frame, smoothed noise for textures, and OpenCV's sub-pixel drawing constants.
"""

from __future__ import annotations

import math
from typing import Protocol, cast

import cv2
import numpy as np

SHIFT = 4  # fractional bits of the sub-pixel coordinates given to OpenCV's drawing functions
ONE = 1 << SHIFT
LINE = cv2.LINE_8  # no anti-aliasing: the label masks are exactly the drawn pixels


def smooth_noise(
    rng: np.random.Generator, shape: tuple[int, int], sigma: float, channels: int = 1
) -> np.ndarray:
    """Smoothed Gaussian noise with unit spread, float32 (H, W) or (H, W, C)."""
    size = (*shape, channels) if channels > 1 else shape
    raw = rng.standard_normal(size).astype(np.float32)
    smooth = (
        cv2.GaussianBlur(raw, (0, 0), sigma, borderType=cv2.BORDER_REFLECT) if sigma > 0 else raw
    )
    return smooth / max(float(smooth.std()), 1e-6)


def fit_background(image: np.ndarray, width: int, height: int, margin: int) -> np.ndarray:
    if image.ndim == 2:
        image = cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    elif image.shape[2] == 4:
        image = cv2.cvtColor(image, cv2.COLOR_BGRA2BGR)
    image = np.ascontiguousarray(image[:, :, :3]).astype(np.uint8)
    shrink = image.shape[1] > width
    resized = cv2.resize(
        image, (width, height), interpolation=cv2.INTER_AREA if shrink else cv2.INTER_LINEAR
    )
    return cv2.copyMakeBorder(resized, margin, margin, margin, margin, cv2.BORDER_REFLECT)


class CameraEffects(Protocol):
    """What :func:`illumination_gain` and :func:`sensor_effects` read of a scene config (the street's and the
    small-object scenes' configs both have these fields)."""

    @property
    def width(self) -> int: ...
    @property
    def fps(self) -> float: ...
    @property
    def illumination_drift(self) -> float: ...
    @property
    def illumination_period(self) -> float: ...
    @property
    def optical_blur(self) -> float: ...
    @property
    def noise_sigma(self) -> float: ...
    @property
    def jpeg_quality(self) -> int: ...


def illumination_gain(config: CameraEffects, n: int, phases: np.ndarray) -> np.ndarray:
    """(1, W, 1) gain of frame n: a slow global drift and a slowly turning left-right slant."""
    W = config.width
    if config.illumination_drift == 0 or config.illumination_period == 0:
        return np.ones((1, W, 1), np.float32)
    t = n / config.fps
    omega = 2 * math.pi / config.illumination_period
    drift = config.illumination_drift
    slant = 0.4 * drift * math.sin(0.7 * omega * t + phases[1])
    ramp = np.linspace(-0.5, 0.5, W, dtype=np.float32)
    gain = 1.0 + drift * math.sin(omega * t + phases[0]) + slant * ramp
    return gain.astype(np.float32)[None, :, None]


def sensor_effects(
    image: np.ndarray, gain: np.ndarray, rng: np.random.Generator, config: CameraEffects
) -> np.ndarray:
    """Lens blur, lighting, sensor noise and JPEG compression of one rendered frame."""
    if config.optical_blur > 0:
        image = cv2.GaussianBlur(image, (0, 0), config.optical_blur)
    light = image.astype(np.float32) * gain
    if config.noise_sigma > 0:
        light += rng.standard_normal(light.shape, dtype=np.float32) * np.float32(config.noise_sigma)
    out: np.ndarray = np.clip(np.rint(light), 0, 255).astype(np.uint8)
    if config.jpeg_quality > 0:
        ok, data = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, config.jpeg_quality])
        if not ok:
            raise RuntimeError("JPEG encoding failed")
        # imdecode of what imencode just wrote: a decoded image (the stubs allow None)
        out = cast(np.ndarray, cv2.imdecode(data, cv2.IMREAD_COLOR))
    return out
