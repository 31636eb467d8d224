"""Replay timing and read-ahead for video_source (no rclpy).

`Pacer` schedules frames at `rate` x the recording's speed from an anchor (a wall time and the
stamp due then). A rate change re-anchors at the last frame sent, so the replay continues from now
at the new speed: no burst of frames to catch up and no stall.

`Prefetcher` decodes frames ahead in a thread, so decoding frame n+1 overlaps waiting for frame
n's lockstep acknowledgement. `close()` stops and joins that thread: its owner stops it before the
node's publishers go away.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from queue import Empty, Full, Queue

from tracker_msgs_py.codec import NS_PER_S
from tracker_ptz_sim.simulation.frame_sources import Frame

POLL_S = 0.05  # how often a blocked queue operation looks at the close flag


class Pacer:
    """When each frame is due, for a replay at `rate` x real time (0 = as fast as possible)."""

    def __init__(self, rate: float) -> None:
        self.rate = rate
        self._anchor: tuple[float, int] | None = None  # (wall time [s], stamp [ns]) due then
        self._last_stamp_ns: int | None = None

    def set_rate(self, rate: float, now: float) -> None:
        """Change the speed from `now` on: the last frame sent counts as sent at `now`."""
        self.rate = rate
        self._anchor = None if self._last_stamp_ns is None else (now, self._last_stamp_ns)

    def delay(self, stamp_ns: int, now: float) -> float:
        """Seconds to wait from `now` before sending the frame stamped `stamp_ns`."""
        if self.rate <= 0:
            self._anchor = None
            return 0.0
        if self._anchor is None:
            self._anchor = (now, stamp_ns)
        wall, stamp = self._anchor
        return max(0.0, wall + (stamp_ns - stamp) / NS_PER_S / self.rate - now)

    def sent(self, stamp_ns: int) -> None:
        """Record that the frame stamped `stamp_ns` went out."""
        self._last_stamp_ns = stamp_ns


class Prefetcher:
    """Iterates `frames`, decoded up to `depth` frames ahead in a thread of its own."""

    _DONE = object()

    def __init__(self, frames: Iterator[Frame], depth: int = 3) -> None:
        self._frames = frames
        self._queue: Queue = Queue(maxsize=depth)
        self._closed = threading.Event()
        self._thread = threading.Thread(target=self._read, name="prefetch", daemon=True)
        self._thread.start()

    def _read(self) -> None:
        try:
            for frame in self._frames:
                if not self._put(frame):
                    return
            self._put(self._DONE)
        except Exception as error:  # handed to the consumer, which reports it
            self._put(error)
        finally:
            close = getattr(self._frames, "close", None)
            if close is not None:
                close()  # releases the reader's file (a generator's finally) in this thread

    def _put(self, item: object) -> bool:
        while not self._closed.is_set():
            try:
                self._queue.put(item, timeout=POLL_S)
                return True
            except Full:
                continue
        return False

    def __iter__(self) -> Iterator[Frame]:
        while not self._closed.is_set():
            try:
                item = self._queue.get(timeout=POLL_S)
            except Empty:
                continue
            if item is self._DONE:
                return
            if isinstance(item, Exception):
                raise item
            yield item

    def close(self, timeout: float = 1.0) -> bool:
        """Stop reading ahead and wait for the thread; False if it is still decoding a frame."""
        self._closed.set()
        self._thread.join(timeout)
        return not self._thread.is_alive()
