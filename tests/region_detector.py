"""A test-only detector started from a rectangle: it reports the selected region as one blob in
every frame. It proves the `select_region` plumbing of the detector node for seeded methods."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from tracker_detect.detector import Blob, CameraFrame, Detection, StaleFrameError
from tracker_detect.registration import View
from tracker_msgs_py.geometry import Rect
from tracker_msgs_py.registry import Method


@dataclass(frozen=True)
class RegionConfig:
    """The region detector has no parameters."""

    def problems(self) -> list[str]:
        return []


class RegionDetector:
    estimates_ego_motion = False

    def __init__(self, config: RegionConfig | None = None) -> None:
        self.region: Rect | None = None
        self.last_stamp: int | None = None

    def select_region(self, region: Rect, frame: CameraFrame) -> str | None:
        if region.width <= 0 or region.height <= 0:
            return "the region is empty"
        self.region = region
        return None

    def hand_over(self, region: Rect, frame: CameraFrame) -> str | None:
        return self.select_region(region, frame) if self.region is None else "tracking"

    def process(self, frame: CameraFrame) -> Detection:
        if self.last_stamp is not None and frame.stamp_ns <= self.last_stamp:
            raise StaleFrameError(f"stamp {frame.stamp_ns} ns is not newer than the last")
        self.last_stamp = frame.stamp_ns
        view = frame.view or View.identity(*frame.size)
        blobs = []
        if self.region is not None:
            cx, cy = self.region.center
            area = self.region.width * self.region.height
            blobs = [Blob(cx, cy, self.region, area, int(area), 1.0)]
        return Detection(frame.stamp_ns, view, blobs, bool(blobs), True)

    @property
    def tracking(self) -> bool:
        return self.region is not None

    def guide(self, centre: tuple[float, float]) -> None:
        """Moves the reported region to `centre` (so tests can see the node's guidance)."""
        if self.region is not None:
            self.region = Rect.from_center(*centre, self.region.width, self.region.height)

    def reset(self) -> None:
        self.last_stamp = None

    def reconfigure(self, config: RegionConfig) -> None:
        """Nothing to change: the region stays selected."""


METHOD: Method[Any] = Method.of(
    "region_test", "test only: reports the selected region", RegionConfig, RegionDetector
)
