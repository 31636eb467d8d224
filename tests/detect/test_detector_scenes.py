"""Ego-motion compensation of seed 000's k - gap SSIM detector, against synthetic scenes.

These overlap counts say whether compensation keeps the moving camera's own motion out of the
mask (with it off, precision collapses); they are not box accuracy: a k - gap blob covers the old
and the new position. Box-level accuracy (IoU >= 0.5 against the visible box) is asserted in
test_background_detector.py and measured by the benchmark (`make benchmark`).

A camera window is sliced from each scene frame along a known path, so the true window shift is
exact. Scores, pooled over all compared frames:
- object recall: a moving object (its box moved between frame k - gap and k) with at least
  MIN_PIXELS visible pixels in the compared part of the window counts as found when a blob
  overlaps its pixels in frame k;
- blob precision: a blob is correct when it overlaps an object's pixels (frame k or k - gap: a
  frame-difference blob covers both positions) and at least half of it lies within NEAR_PX of
  them (the seed's two dilations grow blobs by 6 px);
- false-positive rate: the fraction of compared background pixels (farther than NEAR_PX from any
  object of frame k or k - gap) marked as motion.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import pytest

from tracker_detect.motion.motion import DetectorConfig, MotionDetector
from tracker_detect.registration import View
from tracker_msgs_py.geometry import Rect
from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

MIN_PIXELS = 30
NEAR_PX = 7
NS = 100_000_000


@dataclass
class Score:
    objects: int = 0
    found: int = 0
    blobs: int = 0
    correct_blobs: int = 0
    background_pixels: int = 0
    false_pixels: int = 0
    frames: int = 0
    max_shift_error: float = 0.0

    @property
    def recall(self) -> float:
        return self.found / max(self.objects, 1)

    @property
    def precision(self) -> float:
        return self.correct_blobs / max(self.blobs, 1)

    @property
    def false_positive_rate(self) -> float:
        return self.false_pixels / max(self.background_pixels, 1)


def run(scene, windows, config, pose="known"):
    """Run the detector over the windows; pose 'known' passes the views, 'unknown' passes None."""
    detector = MotionDetector(config)
    score = Score()
    gap = config.gap
    near_kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * NEAR_PX + 1, 2 * NEAR_PX + 1))
    for k, (x, y, w, h) in enumerate(windows):
        gray = cv2.cvtColor(scene.frames[k, y : y + h, x : x + w], cv2.COLOR_BGR2GRAY)
        view = View(Rect(x, y, w, h), w, h)
        result = detector.process(gray, k * NS, view if pose == "known" else None)
        if not result.compared:
            continue
        score.frames += 1
        px, py = windows[k - gap][:2]
        if pose == "unknown":  # the estimated shift against the true one
            error = max(abs(result.ego_shift[0] - (x - px)), abs(result.ego_shift[1] - (y - py)))
            score.max_shift_error = max(score.max_shift_error, error)
        now = scene.labels[k, y : y + h, x : x + w]
        before = scene.labels[k - gap, y : y + h, x : x + w]
        compared = np.zeros((h, w), bool)
        b = config.ssim.border
        compared[
            max(py - y, 0) + b : min(py - y + h, h) - b, max(px - x, 0) + b : min(px - x + w, w) - b
        ] = True
        count, components = cv2.connectedComponents(result.mask, connectivity=4)
        if pose == "known":
            assert result.view == view
        _check_scene_coordinates(result, components, count, result.view)
        moved_from = {box.object_id: (box.x, box.y) for box in scene.boxes[k - gap]}
        for box in scene.boxes[k]:
            if moved_from.get(box.object_id) == (box.x, box.y):
                continue  # standing still: no frame difference to detect
            pixels = (now == box.object_id) & compared
            if pixels.sum() >= MIN_PIXELS:
                score.objects += 1
                score.found += bool(result.mask[pixels].any())
        truth = ((now > 0) | (before > 0)).astype(np.uint8)
        near = cv2.dilate(truth, near_kernel) > 0
        for i in range(1, count):
            blob = components == i
            score.blobs += 1
            score.correct_blobs += bool(truth[blob].any() and near[blob].mean() >= 0.5)
        background = compared & ~near
        score.background_pixels += int(background.sum())
        score.false_pixels += int((result.mask[background] > 0).sum())
    return score


def _check_scene_coordinates(result, components, count, view):
    """Every mask component is a published blob, its box mapped through the frame's view."""
    assert len(result.blobs) == count - 1
    boxes = {(b.bbox.x, b.bbox.y, b.bbox.width, b.bbox.height) for b in result.blobs}
    for i in range(1, count):
        ys, xs = np.nonzero(components == i)
        box = view.rect_to_scene(
            xs.min(), ys.min(), xs.max() - xs.min() + 1, ys.max() - ys.min() + 1
        )
        assert (box.x, box.y, box.width, box.height) in boxes


def sweep(n, scene_w, scene_h, w, h, speed=8, amplitude=20):
    """A horizontal back-and-forth sweep with a vertical wobble: integer window corners."""
    span = scene_w - w
    xs = np.abs((np.arange(n) * speed) % (2 * span) - span)
    ys = (scene_h - h) / 2 + amplitude * np.sin(np.arange(n) / 4.0)
    return [(int(x), int(round(y)), w, h) for x, y in zip(xs, ys, strict=True)]


def hard_config(width, height, seed, **overrides):
    """Small objects (10-30 px) that turn and stop, two static occluders, sensor noise of 5 grey
    levels, a +-10 % illumination drift with a 5 s period."""
    values = dict(
        width=width,
        height=height,
        num_frames=70,
        fps=10,
        num_objects=8,
        object_size_range=(10, 30),
        speed_range=(20, 60),
        turns=2,
        stops=1,
        num_occluders=2,
        noise_sigma=5.0,
        illumination_drift=0.1,
        illumination_period=5.0,
        seed=seed,
    )
    values.update(overrides)
    return SceneConfig(**values)


@pytest.fixture(scope="module")
def busy_scene():
    return generate_scene(hard_config(320, 240, seed=21))


@pytest.fixture(scope="module")
def wide_scene():
    """A wide surveillance area for a 200 x 160 window sweeping at 9 px/frame (27 px per gap)."""
    return generate_scene(hard_config(480, 320, seed=31, num_objects=12))


def test_static_window_against_ground_truth(busy_scene):
    windows = [(0, 0, 320, 240)] * busy_scene.num_frames
    score = run(busy_scene, windows, DetectorConfig())
    print(
        f"static: recall {score.recall:.3f} ({score.found}/{score.objects}), precision "
        f"{score.precision:.3f} ({score.correct_blobs}/{score.blobs}), "
        f"FP rate {score.false_positive_rate:.5f}"
    )
    assert score.objects >= 100
    assert score.recall >= 0.95
    assert score.precision >= 0.90


def test_objects_entering_and_leaving_a_static_window():
    config = SceneConfig(
        width=320,
        height=240,
        num_frames=60,
        num_objects=5,
        entries_exits=True,
        speed_range=(30, 60),
        seed=23,
    )
    scene = generate_scene(config)
    score = run(scene, [(0, 0, 320, 240)] * scene.num_frames, DetectorConfig())
    print(
        f"entries/exits: recall {score.recall:.3f} ({score.found}/{score.objects}), "
        f"precision {score.precision:.3f} ({score.correct_blobs}/{score.blobs})"
    )
    assert score.objects >= 50
    assert score.recall >= 0.95
    assert score.precision >= 0.90


def test_moving_window_known_shift_and_without_compensation(wide_scene):
    windows = sweep(wide_scene.num_frames, 480, 320, 200, 160, speed=9, amplitude=25)
    known = run(wide_scene, windows, DetectorConfig(compensation="known"))
    off = run(wide_scene, windows, DetectorConfig(compensation="off"))
    print(
        f"moving, known shift: recall {known.recall:.3f} ({known.found}/{known.objects}), "
        f"precision {known.precision:.3f} ({known.correct_blobs}/{known.blobs}), "
        f"FP rate {known.false_positive_rate:.5f}; compensation off: FP rate "
        f"{off.false_positive_rate:.5f}, precision {off.precision:.3f}"
    )
    assert known.objects >= 50
    assert known.recall >= 0.95
    assert known.precision >= 0.90
    assert off.false_positive_rate >= 5 * max(known.false_positive_rate, 0.001)
    assert off.precision < 0.5


@pytest.mark.parametrize("estimator", ["phase_correlation", "ssim_search"])
def test_moving_window_with_estimated_shift(wide_scene, estimator):
    """No pose at all: the estimated shift must be the true window shift within 1 px."""
    windows = sweep(wide_scene.num_frames, 480, 320, 200, 160, speed=9, amplitude=25)
    config = DetectorConfig(compensation=estimator)
    score = run(wide_scene, windows, config, pose="unknown")
    print(
        f"{estimator}: max shift error {score.max_shift_error:.3f} px, recall "
        f"{score.recall:.3f}, precision {score.precision:.3f}"
    )
    assert score.max_shift_error <= 1.0
    assert score.recall >= 0.95
    assert score.precision >= 0.90


def test_jittery_camera_needs_the_estimator():
    """A static camera shaking by up to 3 px: with the pose known only as 'static', the
    estimator removes the jitter (seed: camera vibration is what the SSIM search is for)."""
    config = SceneConfig(
        width=240,
        height=180,
        num_frames=40,
        num_objects=3,
        camera_jitter=3,
        speed_range=(30, 60),
        seed=24,
    )
    scene = generate_scene(config)
    windows = [(0, 0, 240, 180)] * scene.num_frames
    static = run(scene, windows, DetectorConfig(compensation="known"))
    for estimator in ("phase_correlation", "ssim_search"):
        steady = run(scene, windows, DetectorConfig(compensation=estimator, search_radius=8))
        print(
            f"jitter, {estimator}: FP rate {steady.false_positive_rate:.5f} vs "
            f"{static.false_positive_rate:.5f} uncompensated"
        )
        assert steady.false_positive_rate * 5 <= static.false_positive_rate
        assert steady.precision >= 0.9
