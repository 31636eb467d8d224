"""Holds a seeded detector's images until the targets that decide how they are processed have
come (no rclpy), so a lockstep replay gives the same result every time.

A seeded detector (CamShift) reads two target streams besides its images: the hand-over target
of the image's own stamp (another tracker's, answering every image: a locked, measured target
starts tracking when the detector is not tracking) and its own tracker's target of the image
before (its prediction places the search window). In a live graph they are used as they come; in
a lockstep replay their arrival order against the next image is up to the transport, so each
image waits here until
- the hand-over stream has answered its stamp (its target, or a newer one: that stamp's will
  not come), and
- its own tracker has answered the image released before it (a target stamped at or after it),
- or the image has waited `timeout` seconds (a tracker that is down), or more than `capacity`
  images wait.
Images are released in arrival order, each exactly once, with the hand-over target of their
stamp when it came.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from typing import Any


@dataclass
class HeldImage:
    stamp_ns: int
    item: Any  # what the node processes for this image
    arrived: float  # monotonic seconds
    handover: Any = None  # the hand-over target of this stamp, when it came
    timed_out: bool = False


class TargetGate:
    """See the module docstring. `handover` / `guide`: which streams an image waits for."""

    def __init__(
        self, handover: bool, guide: bool, timeout: float = 1.0, capacity: int = 30
    ) -> None:
        if timeout <= 0 or capacity < 1:
            raise ValueError("timeout must be > 0 and capacity >= 1")
        self.wait_handover, self.wait_guide = handover, guide
        self.timeout, self.capacity = timeout, capacity
        self._held: deque[HeldImage] = deque()
        self._handovers: dict[int, Any] = {}
        self._newest_handover: int | None = None
        self._newest_guide: int | None = None
        self._last_released: int | None = None

    def __len__(self) -> int:
        return len(self._held)

    def add_image(self, stamp_ns: int, item: Any, now: float) -> list[HeldImage]:
        self._held.append(HeldImage(stamp_ns, item, now))
        return self._ready(now)

    def add_handover(self, stamp_ns: int, target: Any, now: float) -> list[HeldImage]:
        """The hand-over stream's answer to the image stamped `stamp_ns`."""
        self._handovers[stamp_ns] = target
        if self._newest_handover is None or stamp_ns > self._newest_handover:
            self._newest_handover = stamp_ns
        return self._ready(now)

    def add_guide(self, stamp_ns: int, now: float) -> list[HeldImage]:
        """The own tracker's answer to the image stamped `stamp_ns`."""
        if self._newest_guide is None or stamp_ns > self._newest_guide:
            self._newest_guide = stamp_ns
        return self._ready(now)

    def expire(self, now: float) -> list[HeldImage]:
        """Release what has waited `timeout` seconds (and what waits behind it, if ready)."""
        return self._ready(now)

    def clear(self) -> list[HeldImage]:
        """A new epoch: release every held image as it is and forget the targets."""
        released = list(self._held)
        for held in released:
            held.handover = self._handovers.get(held.stamp_ns)
        self._held.clear()
        self._handovers.clear()
        self._newest_handover = self._newest_guide = self._last_released = None
        return released

    def _answered(self, held: HeldImage) -> bool:
        handover_done = not self.wait_handover or (
            self._newest_handover is not None and self._newest_handover >= held.stamp_ns
        )
        guide_done = (
            not self.wait_guide
            or self._last_released is None
            or (self._newest_guide is not None and self._newest_guide >= self._last_released)
        )
        return handover_done and guide_done

    def _ready(self, now: float) -> list[HeldImage]:
        released = []
        while self._held:
            held = self._held[0]
            late = now - held.arrived >= self.timeout
            if not (self._answered(held) or late or len(self._held) > self.capacity):
                break
            self._held.popleft()
            held.handover = self._handovers.get(held.stamp_ns)
            held.timed_out = late and not self._answered(held)
            for stamp in [s for s in self._handovers if s <= held.stamp_ns]:
                del self._handovers[stamp]
            self._last_released = held.stamp_ns
            released.append(held)
        return released
