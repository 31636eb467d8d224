"""Order of the stamps on one input stream, and replay epochs (no rclpy).

DDS delivers the samples of one writer in order, so on a stream from one source a stamp can only:
- increase: the next message (`Order.NEXT`);
- repeat: the same message again, e.g. a lockstep re-send (`Order.REPEAT`): drop it;
- go back: the source restarted or looped (a respawned video_source, `ros2 bag play --loop`, a
  camera driver restarted with a new clock). That is a new *epoch* (`Order.NEW_EPOCH`): the node
  accepts the message and forgets the state it built on the old stamps, as tf2 clears its buffer
  when time jumps back.
- leap ahead by more than the stream's `max_gap_ns`, where one is set: the input stopped (a live
  camera that dropped out and came back). Also a new epoch: what was predicted before the gap is
  not extrapolated across it.

A stamp that is not a valid time (negative) is `Order.INVALID`.
"""

from __future__ import annotations

from enum import Enum

from tracker_msgs_py.codec import NS_PER_S


class Order(Enum):
    NEXT = "next"
    REPEAT = "repeat"
    NEW_EPOCH = "new epoch"
    INVALID = "invalid"


class StampOrder:
    """Classifies each stamp of a stream against the last accepted one."""

    def __init__(self, max_gap_ns: int | None = None) -> None:
        self.max_gap_ns = max_gap_ns  # a longer step forward is a new epoch (None: never)
        self.last_ns: int | None = None
        self.jumped_from_ns: int | None = None  # the last stamp before the latest new epoch
        self.epochs = 0  # new epochs seen after the first message

    def classify(self, stamp_ns: int) -> Order:
        """What `check` would answer, without accepting anything."""
        if stamp_ns < 0:
            return Order.INVALID
        if self.last_ns is None:
            return Order.NEXT
        if stamp_ns > self.last_ns:
            leap = self.max_gap_ns is not None and stamp_ns - self.last_ns > self.max_gap_ns
            return Order.NEW_EPOCH if leap else Order.NEXT
        return Order.REPEAT if stamp_ns == self.last_ns else Order.NEW_EPOCH

    def check(self, stamp_ns: int) -> Order:
        """Classify `stamp_ns` and, unless it is a repeat or invalid, accept it as the last."""
        order = self.classify(stamp_ns)
        if order in (Order.REPEAT, Order.INVALID):
            return order
        if order is Order.NEW_EPOCH:
            self.epochs += 1
            self.jumped_from_ns = self.last_ns
        self.last_ns = stamp_ns
        return order

    def describe_jump(self) -> str:
        """'stamps jumped back 12.300 s, to 0.000 s' (or 'ahead'), for the log line of the latest
        new epoch."""
        if self.jumped_from_ns is None or self.last_ns is None:
            return "no jump yet"
        step = (self.last_ns - self.jumped_from_ns) / NS_PER_S
        direction = "ahead" if step > 0 else "back"
        return f"stamps jumped {direction} {abs(step):.3f} s, to {self.last_ns / NS_PER_S:.3f} s"

    def reset(self) -> None:
        self.last_ns = None
