"""Pinhole images onto the scene's equiangular grid: the linear view is exact after it."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from tracker_detect.pinhole import pinhole_focal, pinhole_view, to_equiangular

FOCAL = 400.0  # scene px per rad
SPOTS = [(-250.0, -150.0), (-120.0, 90.0), (0.0, 0.0), (160.0, -60.0), (240.0, 170.0)]


def spots_scene(width: int, height: int) -> np.ndarray:
    """Bright blurred spots at SPOTS (scene px from the centre) on black."""
    scene = np.zeros((height, width), np.float32)
    for dx, dy in SPOTS:
        cv2.circle(scene, (round(width / 2 + dx), round(height / 2 + dy)), 3, 255.0, -1)
    return cv2.GaussianBlur(scene, (0, 0), 2.0)


def spot_centres(image: np.ndarray) -> list[tuple[float, float]]:
    """Intensity-weighted centres of the image's spots, offsets from the image centre, in the
    order of SPOTS (nearest first)."""
    count, labels = cv2.connectedComponents((image > 20).astype(np.uint8))
    found = []
    for label in range(1, count):
        ys, xs = np.nonzero(labels == label)
        weights = image[ys, xs]
        x = float(np.average(xs, weights=weights)) + 0.5 - image.shape[1] / 2
        y = float(np.average(ys, weights=weights)) + 0.5 - image.shape[0] / 2
        found.append((x, y))
    return found


def nearest(found, x, y):
    return min(found, key=lambda p: math.hypot(p[0] - x, p[1] - y))


def test_a_wide_pinhole_image_misplaces_the_scene_and_its_rectification_does_not():
    """A 77 degree pinhole camera: a linear window over its edge rays misplaces a spot halfway out
    by several pixels; the image resampled onto the equiangular grid puts each within 0.2 px."""
    scene = spots_scene(640, 480)
    size = (640, 480)
    span = (2 * FOCAL * math.atan(320 / FOCAL), 2 * FOCAL * math.atan(240 / FOCAL))
    image = pinhole_view(scene, size, span, FOCAL)
    scale = (span[0] / size[0], span[1] / size[1])  # scene px per pixel of the linear view
    raw = spot_centres(image)
    rectified = spot_centres(to_equiangular(image, span, FOCAL))
    worst_raw = worst_rectified = 0.0
    for dx, dy in SPOTS:
        # where the linear view puts the spot (drawn on the pixel whose centre is 0.5 further)
        expected = ((dx + 0.5) / scale[0], (dy + 0.5) / scale[1])
        rx, ry = nearest(raw, *expected)
        qx, qy = nearest(rectified, *expected)
        worst_raw = max(worst_raw, math.hypot(rx - expected[0], ry - expected[1]))
        worst_rectified = max(worst_rectified, math.hypot(qx - expected[0], qy - expected[1]))
    assert worst_raw > 5.0
    assert worst_rectified < 0.2


def test_the_pinhole_focal_is_the_one_whose_edge_rays_span_the_window():
    fx = pinhole_focal(640, 2 * FOCAL * math.atan(320 / 500.0), FOCAL)
    assert fx == pytest.approx(500.0)
    # a narrow view is nearly linear: the focal is the scene's, scaled by pixels per span
    assert pinhole_focal(100, 10.0, FOCAL) == pytest.approx(FOCAL * 100 / 10.0, rel=1e-3)
