"""Ego-motion compensation: known shifts, both estimators against true window shifts, alignment."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from tracker_detect.registration import (
    CameraIntrinsics,
    PixelMap,
    View,
    align,
    phase_correlation_shift,
    relative_map,
    ssim_shift_search,
    view_from_pan_tilt,
)
from tracker_msgs_py.geometry import Rect, SceneGeometry
from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene


@pytest.fixture(scope="module")
def scene_gray():
    """A textured scene with moving objects (frame 0 and frame 3), grey."""
    scene = generate_scene(SceneConfig(width=400, height=320, num_frames=4, num_objects=3, seed=5))
    return [cv2.cvtColor(f, cv2.COLOR_BGR2GRAY) for f in scene.frames]


def window(image, x, y, w, h):
    return image[y : y + h, x : x + w]


def test_known_shift_is_the_window_displacement_seed_example():
    """Seed §4, option 1: window centres [80, 60] -> [50, 40] give a shift of (-30, -20)."""
    prev = View(Rect.from_center(80, 60, 110, 110), 110, 110)
    curr = View(Rect.from_center(50, 40, 110, 110), 110, 110)
    m = relative_map(prev, curr)
    assert (m.sx, m.sy, m.tx, m.ty) == (1.0, 1.0, -30.0, -20.0)


def test_seed_fig_5_9_black_block_moved_15_px_right():
    """Seed Fig 5.9/5.10: a black block on white moved 15 px right; the search peaks at 15 px."""
    prev = np.full((110, 110), 255, np.uint8)
    prev[40:70, 30:60] = 0
    curr = np.roll(prev, 15, axis=1)
    estimate = ssim_shift_search(prev, curr, radius=30)
    # the content moved right, i.e. the camera moved 15 px left
    assert (estimate.dx, estimate.dy) == (-15.0, 0.0)
    assert estimate.score == pytest.approx(1.0, abs=1e-6)


@pytest.mark.parametrize("levels", [0, 2])
def test_ssim_search_finds_the_true_window_shift(scene_gray, levels):
    """Exhaustive (seed) and coarse-to-fine search, +-30 px, with objects moving in between."""
    rng = np.random.default_rng(10 + levels)
    size = 96 if levels == 0 else 160  # the exhaustive search is slow: keep its images small
    for _ in range(4):
        dx, dy = (int(v) for v in rng.integers(-28, 29, 2))
        x0, y0 = 120, 100
        prev = window(scene_gray[0], x0, y0, size, size)
        curr = window(scene_gray[3], x0 + dx, y0 + dy, size, size)
        estimate = ssim_shift_search(prev, curr, radius=30, pyramid_levels=levels)
        assert abs(estimate.dx - dx) <= 1 and abs(estimate.dy - dy) <= 1, (dx, dy, estimate)


def test_ssim_search_respects_the_prior(scene_gray):
    """Searching +-3 px around a known shift of (40, -35) finds the residual jitter."""
    prev = window(scene_gray[0], 150, 120, 128, 128)
    curr = window(scene_gray[3], 150 + 42, 120 - 36, 128, 128)
    estimate = ssim_shift_search(prev, curr, radius=3, prior=(40, -35))
    assert (estimate.dx, estimate.dy) == (42.0, -36.0)


def test_phase_correlation_finds_fractional_window_shifts(scene_gray):
    """Windows rendered at sub-pixel positions (bilinear), as a continuous pan would give."""
    rng = np.random.default_rng(11)
    errors = []
    for _ in range(10):
        d = rng.uniform(-25, 25, 2)
        centre = np.array([200.0, 160.0])
        prev = cv2.getRectSubPix(scene_gray[0], (128, 128), tuple(centre))
        curr = cv2.getRectSubPix(scene_gray[3], (128, 128), tuple(centre + d))
        estimate = phase_correlation_shift(prev, curr)
        errors.append(max(abs(estimate.dx - d[0]), abs(estimate.dy - d[1])))
    assert max(errors) <= 1.0
    assert np.mean(errors) < 0.35


def test_phase_correlation_with_a_prior(scene_gray):
    prev = window(scene_gray[0], 100, 100, 128, 128)
    curr = window(scene_gray[3], 100 + 70, 100 + 5, 128, 128)
    estimate = phase_correlation_shift(prev, curr, prior=(68, 4))
    assert abs(estimate.dx - 70) <= 1 and abs(estimate.dy - 5) <= 1
    assert estimate.score > 0.2


def test_estimators_reject_mismatched_images():
    with pytest.raises(ValueError):
        ssim_shift_search(np.zeros((50, 50)), np.zeros((50, 60)))
    with pytest.raises(ValueError):
        phase_correlation_shift(np.zeros((50, 50)), np.zeros((40, 50)))


def test_integer_alignment_crops_the_common_part(scene_gray):
    img = scene_gray[0]
    prev = window(img, 50, 60, 100, 80)
    curr = window(img, 57, 49, 100, 80)  # the camera moved (+7, -11)
    aligned = align(prev, curr, PixelMap(tx=7, ty=-11))
    assert aligned.roi == (0, 11, 93, 80)
    np.testing.assert_array_equal(aligned.prev, aligned.curr)


def test_fractional_alignment_resamples_the_previous_image(scene_gray):
    img = scene_gray[0].astype(np.float32)
    prev = cv2.getRectSubPix(img, (100, 100), (150.0, 150.0))
    curr = cv2.getRectSubPix(img, (100, 100), (150.0 + 6.4, 150.0 - 3.7))
    aligned = align(prev, curr, PixelMap(tx=6.4, ty=-3.7))
    x0, y0, x1, y1 = aligned.roi
    assert (x0, y0) == (0, 4) and x1 <= 94 and y1 == 100
    diff = np.abs(aligned.prev.astype(np.float32) - aligned.curr)
    assert diff.mean() < 3.0  # grey levels; bilinear twice vs once


def test_alignment_handles_a_zoom_change(scene_gray):
    """The current view shows half the scene area at the same image size (zoom x2)."""
    img = scene_gray[0].astype(np.float32)
    prev_view = View(Rect(100, 80, 160, 120), 160, 120)
    curr_view = View(Rect(140, 110, 80, 60), 160, 120)

    def render(view):
        sx = view.scale_x
        matrix = np.float32(
            [[sx, 0, view.rect.x + 0.5 * sx - 0.5], [0, sx, view.rect.y + 0.5 * sx - 0.5]]
        )
        flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
        return cv2.warpAffine(img, matrix, (view.width, view.height), flags=flags)

    aligned = align(render(prev_view), render(curr_view), relative_map(prev_view, curr_view))
    assert aligned.roi == (0, 0, 160, 120)
    assert np.abs(aligned.prev - aligned.curr).mean() < 3.0


def test_no_overlap_gives_none():
    assert align(np.zeros((50, 50)), np.zeros((50, 50)), PixelMap(tx=60)) is None
    assert align(np.zeros((50, 50)), np.zeros((50, 50)), PixelMap(tx=60.5)) is None


def test_view_from_pan_tilt_follows_the_scene_geometry():
    camera = CameraIntrinsics(width=320, height=240, fx=400.0, fy=400.0, cx=160.0, cy=120.0)
    scene = SceneGeometry(width=2000, height=1000, focal_length=400.0)
    home = view_from_pan_tilt(0.0, 0.0, camera, scene)
    assert home.rect.center == pytest.approx((1000.0, 500.0))
    # equiangular scene: the edges are at atan of the half-size, close to the pinhole's 160 px
    assert home.rect.width == pytest.approx(2 * 400 * math.atan(160 / 400))
    assert home.scale_x == pytest.approx(1.0, abs=0.06)
    left = view_from_pan_tilt(0.1, 0.0, camera, scene)  # pan positive = left
    assert left.rect.x == pytest.approx(home.rect.x - 40.0)
    down = view_from_pan_tilt(0.0, 0.05, camera, scene)  # tilt positive = down
    assert down.rect.y == pytest.approx(home.rect.y + 20.0)
    shift = relative_map(home, left)
    assert shift.tx == pytest.approx(-40.0 / home.scale_x)


def test_view_rejects_bad_input():
    with pytest.raises(ValueError):
        View(Rect(0, 0, float("nan"), 10), 10, 10)
    with pytest.raises(ValueError):
        CameraIntrinsics(10, 10, 0.0, 1.0, 5.0, 5.0)
    camera = CameraIntrinsics(10, 10, 10.0, 10.0, 5.0, 5.0)
    with pytest.raises(ValueError):
        view_from_pan_tilt(float("inf"), 0.0, camera, SceneGeometry(100, 100, 10.0))
