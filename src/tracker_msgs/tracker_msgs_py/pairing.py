"""Pairs the messages of one frame that arrive on different topics, by header stamp (no rclpy).

A node is driven by one stream (the tracker by detections): each of its messages opens a frame,
and the frame is released, in arrival order, once every other part it needs has arrived with the
same stamp. Parts come in stamp order per stream, so a part stamped after a waiting frame means
that frame's part will never come: the frame is then released with that part missing (None),
as it is when more than `capacity` frames wait. Nothing is ever dropped silently: every frame
opened is released exactly once, which keeps a lockstep replay's one-answer-per-frame promise.
"""

from __future__ import annotations

from collections import OrderedDict, deque
from dataclasses import dataclass, field
from typing import Any


@dataclass
class Frame:
    """A frame opened by the driving stream, with the parts gathered for its stamp."""

    stamp_ns: int
    primary: Any
    parts: dict[str, Any] = field(default_factory=dict)
    missing: tuple[str, ...] = ()  # needed parts that never came (None in `parts`)


class FrameAssembler:
    """Gathers the `needed` parts of each frame; see the module docstring."""

    def __init__(self, needed: tuple[str, ...] | frozenset[str], capacity: int = 30) -> None:
        if capacity < 1:
            raise ValueError(f"capacity must be >= 1, got {capacity}")
        self.needed = tuple(sorted(needed))
        self.capacity = capacity
        self._waiting: deque[Frame] = deque()
        self._parts: dict[str, OrderedDict[int, Any]] = {name: OrderedDict() for name in needed}
        self._newest: dict[str, int] = {}

    def __len__(self) -> int:
        return len(self._waiting)

    def clear(self) -> list[Frame]:
        """Forget the stored parts (a new epoch); returns the frames that were waiting, released."""
        released = [self._release(frame) for frame in self._waiting]
        self._waiting.clear()
        for stored in self._parts.values():
            stored.clear()
        self._newest.clear()
        return released

    def add_primary(self, stamp_ns: int, message: Any) -> list[Frame]:
        """Open a frame; returns the frames now complete (or given up), oldest first."""
        self._waiting.append(Frame(stamp_ns, message))
        return self._ready()

    def add_part(self, name: str, stamp_ns: int, value: Any) -> list[Frame]:
        """Store a part of the frame stamped `stamp_ns`; returns the frames now ready."""
        stored = self._parts[name]
        stored[stamp_ns] = value
        while len(stored) > self.capacity:
            stored.popitem(last=False)
        self._newest[name] = max(stamp_ns, self._newest.get(name, stamp_ns))
        return self._ready()

    def _ready(self) -> list[Frame]:
        released = []
        while self._waiting:
            frame = self._waiting[0]
            complete = all(frame.stamp_ns in self._parts[name] for name in self.needed)
            hopeless = any(
                frame.stamp_ns not in self._parts[name]
                and self._newest.get(name, frame.stamp_ns) > frame.stamp_ns
                for name in self.needed
            )
            if not (complete or hopeless or len(self._waiting) > self.capacity):
                break
            released.append(self._release(self._waiting.popleft()))
        return released

    def _release(self, frame: Frame) -> Frame:
        frame.parts = {name: self._parts[name].pop(frame.stamp_ns, None) for name in self.needed}
        frame.missing = tuple(name for name, value in frame.parts.items() if value is None)
        for stored in self._parts.values():  # parts older than a released frame are never needed
            for stamp in [s for s in stored if s < frame.stamp_ns]:
                del stored[stamp]
        return frame
