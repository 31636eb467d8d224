"""Colour-histogram helpers shared by the detectors and the trackers (no rclpy)."""

from __future__ import annotations

import numpy as np


def background_weights(surroundings: np.ndarray) -> np.ndarray:
    """Comaniciu's background-weighted histogram: bin u weighs min(o* / o_u, 1), o* the smallest
    non-zero count of the surroundings' histogram o; colours absent around the target weigh 1."""
    present = surroundings > 0
    if not present.any():
        return np.ones_like(surroundings)
    rarest = surroundings[present].min()
    return np.where(present, rarest / np.maximum(surroundings, rarest), 1.0).astype(np.float32)
