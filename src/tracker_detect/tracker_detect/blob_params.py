"""The blob parameters several detectors share, declared once (no rclpy).

Each is a `tracker_msgs_py.params.param` field maker: a detector's config writes
``connectivity: int = connectivity(8)`` and gets the one description, range and check.
"""

from __future__ import annotations

from typing import Any

from tracker_msgs_py.params import param


def connectivity(default: int) -> Any:
    return param(
        default,
        "blob pixel connectivity (4 or 8)",
        min=4,
        max=8,
        validator=lambda v: None if v in (4, 8) else "connectivity must be 4 or 8",
    )


def min_blob_area(default: float) -> Any:
    return param(default, "drop blobs smaller than this", min=0.0, max=1e9, unit="scene px^2")


def presence_fraction(default: float) -> Any:
    return param(
        default,
        "presence test: total blob area >= this fraction of the compared area",
        min=0.0,
        max=1.0,
    )


def auto_downsample(default: bool) -> Any:
    return param(default, "Wang's automatic downsampling, f = round(min(H, W) / 256)")


def odd_side(default: int, description: str, name: str) -> Any:
    """An odd side of a square or elliptic element, 1 to 51 px."""
    return param(
        default,
        description,
        min=1,
        max=51,
        unit="px",
        validator=lambda v: None if v % 2 else f"{name} must be odd",
    )
