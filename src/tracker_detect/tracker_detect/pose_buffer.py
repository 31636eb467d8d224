"""Pairs camera images with the pan-tilt pose of the moment they were taken (no rclpy).

Poses (a PtzState's window, or a JointState's pan/tilt) arrive on their own topic, before or
after the image with the same stamp. `PoseBuffer` keeps the recent ones and answers, for an
image stamp: the pose (exact stamp, or linearly interpolated between the two poses around it
when they are at most `max_gap_ns` apart, for pan-tilt units that report at their own rate),
"wait" (no pose that new yet), or "missing" (the pose for that moment will never come).
"""

from __future__ import annotations

import bisect
import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass


class PoseStatus(enum.Enum):
    FOUND = "found"
    WAIT = "wait"  # the newest pose is older than the stamp: it may still arrive
    MISSING = "missing"  # older than every pose kept, or between poses too far apart


@dataclass(frozen=True)
class PoseLookup:
    status: PoseStatus
    values: tuple[float, ...] | None = None  # the pose (interpolated) when FOUND


class PoseBuffer:
    """The last `capacity` poses (tuples of floats), sorted by stamp, for lookup by image stamp."""

    def __init__(self, capacity: int = 64, max_gap_ns: int = 0) -> None:
        if capacity < 2:
            raise ValueError(f"capacity must be >= 2, got {capacity}")
        if max_gap_ns < 0:
            raise ValueError(f"max_gap_ns must be >= 0, got {max_gap_ns}")
        self.capacity = capacity
        self.max_gap_ns = max_gap_ns
        self._stamps: list[int] = []
        self._values: list[tuple[float, ...]] = []

    def __len__(self) -> int:
        return len(self._stamps)

    @property
    def newest_stamp(self) -> int | None:
        return self._stamps[-1] if self._stamps else None

    def clear(self) -> None:
        self._stamps.clear()
        self._values.clear()

    def drop_after(self, stamp_ns: int) -> int:
        """Forget the poses stamped after `stamp_ns` (a new epoch: time jumped back); how many."""
        i = bisect.bisect_right(self._stamps, stamp_ns)
        dropped = len(self._stamps) - i
        del self._stamps[i:], self._values[i:]
        return dropped

    def add(self, stamp_ns: int, values: Sequence[float]) -> None:
        """Store a pose; non-finite values raise ValueError, a repeated stamp replaces the pose."""
        pose = tuple(float(v) for v in values)
        if not all(math.isfinite(v) for v in pose):
            raise ValueError(f"pose at {stamp_ns} ns has non-finite values {pose}")
        i = bisect.bisect_left(self._stamps, stamp_ns)
        if i < len(self._stamps) and self._stamps[i] == stamp_ns:
            self._values[i] = pose
            return
        self._stamps.insert(i, stamp_ns)
        self._values.insert(i, pose)
        if len(self._stamps) > self.capacity:
            del self._stamps[0], self._values[0]

    def lookup(self, stamp_ns: int) -> PoseLookup:
        """The pose at `stamp_ns`: exact, interpolated, WAIT or MISSING (see the module doc)."""
        stamps = self._stamps
        if not stamps or stamp_ns > stamps[-1]:
            return PoseLookup(PoseStatus.WAIT)
        i = bisect.bisect_left(stamps, stamp_ns)
        if stamps[i] == stamp_ns:
            return PoseLookup(PoseStatus.FOUND, self._values[i])
        if i == 0 or stamps[i] - stamps[i - 1] > self.max_gap_ns:
            return PoseLookup(PoseStatus.MISSING)
        t0, t1 = stamps[i - 1], stamps[i]
        w = (stamp_ns - t0) / (t1 - t0)
        a, b = self._values[i - 1], self._values[i]
        return PoseLookup(
            PoseStatus.FOUND, tuple(x + w * (y - x) for x, y in zip(a, b, strict=True))
        )
