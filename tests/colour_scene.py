"""A coloured target (a red-coated walker) over a textured, low-saturation street: the scene the
CamShift tests share (tests/detect/test_camshift.py, test_camshift_node.py)."""

from __future__ import annotations

import math

import cv2
import numpy as np

from tracker_msgs_py.geometry import Rect

SCENE_W, SCENE_H = 480, 360
TARGET_BGR = (40, 60, 200)  # a red coat
AXES = (14, 30)  # the target's ellipse semi-axes [scene px]: a standing person's proportions


def background(seed: int = 0) -> np.ndarray:
    """A textured scene of low-saturation colours (streets, walls) with a green and a blue patch."""
    rng = np.random.default_rng(seed)
    grey = rng.integers(70, 160, (SCENE_H // 8, SCENE_W // 8, 1), dtype=np.uint8)
    tint = rng.integers(-12, 12, (SCENE_H // 8, SCENE_W // 8, 3))
    small = np.clip(grey.astype(int) + tint, 0, 255).astype(np.uint8)
    scene = cv2.resize(small, (SCENE_W, SCENE_H), interpolation=cv2.INTER_LINEAR)
    scene[20:80, 300:380] = (60, 160, 60)
    scene[250:330, 40:120] = (180, 90, 40)
    return scene


def target_position(k: int) -> tuple[float, float]:
    """A walk across the scene with a bend."""
    return 80.0 + 4.0 * k, 180.0 + 40.0 * math.sin(k / 12.0)


def true_box(cx: float, cy: float) -> Rect:
    return Rect.from_center(cx, cy, 2.0 * AXES[0], 2.0 * AXES[1])


def scene_with_target(k: int, *, visible: bool = True, position=None) -> np.ndarray:
    scene = background()
    if visible:
        cx, cy = position or target_position(k)
        inside = np.zeros(scene.shape[:2], np.uint8)
        cv2.ellipse(inside, (round(cx), round(cy)), AXES, 0, 0, 360, 1, -1)
        rng = np.random.default_rng(k)  # cloth texture and a per-frame change of light
        light = rng.uniform(0.85, 1.15)
        cloth = np.array(TARGET_BGR) * light + rng.normal(0.0, 10.0, (int(inside.sum()), 3))
        scene[inside > 0] = np.clip(cloth, 0, 255).astype(np.uint8)
    return scene
