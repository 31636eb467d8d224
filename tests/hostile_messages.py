"""Seeded hostile messages for the nodes' property tests (issue: hostile inputs).

A hostile message is a good one with one field the node reads made non-finite, huge or (where the
field must be positive) negative, stamped where no good message is (between two frames, far ahead,
back in time, before zero) or where one is too (the last frame again, the next frame's before its
good message comes). A node must refuse it or answer it
harmlessly: the answers to the good messages around it are a clean run's.
"""

from __future__ import annotations

import copy
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

NON_FINITE_OR_HUGE = (math.nan, math.inf, -math.inf, 1e308, -1e308, 1e12, -1e12)
NEGATIVE = (-1.0, -1e-9, -1e6)
FAR_AHEAD_NS = 10_000 * 10**9


@dataclass(frozen=True)
class Field:
    """A numeric field of a message by its path ('track.x', 'window.width', 'position[1]', or
    'blobs[*].area' for every element); `positive` when a negative value is invalid too,
    `nan_means_unset` when NaN is a valid value."""

    path: str
    positive: bool = False
    nan_means_unset: bool = False  # NaN is a valid value (JointState: not given)


def set_field(msg: Any, path: str, value: float) -> None:
    """Set the field at `path` (see `Field`) to `value`."""
    *parents, leaf = path.split(".")
    owners = [msg]
    for part in parents:
        owners = [child for owner in owners for child in _children(owner, part)]
    name, index = _split_index(leaf)
    for owner in owners:
        if index is None:
            setattr(owner, name, value)
            continue
        values = list(getattr(owner, name))
        if index == "*":
            values = [value] * len(values)
        else:
            values[int(index)] = value
        setattr(owner, name, values)


def _children(owner: Any, part: str) -> list[Any]:
    name, index = _split_index(part)
    child = getattr(owner, name)
    if index is None:
        return [child]
    return list(child) if index == "*" else [child[int(index)]]


def _split_index(part: str) -> tuple[str, str | None]:
    match = re.fullmatch(r"(\w+)\[(\*|\d+)\]", part)
    return (match.group(1), match.group(2)) if match else (part, None)


def hostile_stamp(rng: np.random.Generator, last_good_ns: int, frame_ns: int) -> int | None:
    """A stamp no good message carries (None: before zero, which a Time cannot hold in ns)."""
    kind = rng.integers(6)
    if kind == 5:
        return last_good_ns + frame_ns  # the next frame's, before its good message comes
    if kind == 0:
        return last_good_ns + int(rng.integers(1, frame_ns))  # between two frames
    if kind == 1:
        return last_good_ns + FAR_AHEAD_NS + int(rng.integers(frame_ns))
    if kind == 2:
        return max(0, last_good_ns - int(rng.integers(1, 6)) * frame_ns)  # back in time
    if kind == 3:
        return last_good_ns  # the last good frame again
    return None


def spoil(
    rng: np.random.Generator,
    good: Any,
    fields: Sequence[Field],
    last_good_ns: int,
    frame_ns: int,
) -> tuple[Any, str]:
    """A copy of `good` with one of `fields` spoiled and a hostile stamp; and what was done."""
    msg = copy.deepcopy(good)
    field = fields[int(rng.integers(len(fields)))]
    choices = NON_FINITE_OR_HUGE + (NEGATIVE if field.positive else ())
    if field.nan_means_unset:
        choices = tuple(v for v in choices if not math.isnan(v))
    value = float(choices[int(rng.integers(len(choices)))])
    set_field(msg, field.path, value)
    stamp = hostile_stamp(rng, last_good_ns, frame_ns)
    if stamp is None:
        msg.header.stamp.sec = -int(rng.integers(1, 100))
    else:
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 10**9)
    return msg, f"{field.path} = {value} at {stamp if stamp is not None else 'sec < 0'}"


@dataclass(frozen=True)
class HostileSource:
    """Hostile messages for one input topic of a node: `make_good(stamp_ns)` gives a message that
    is good at that stamp, `fields` what may be spoiled."""

    topic: str
    make_good: Callable[[int], Any]
    fields: Sequence[Field]


HOSTILE_PER_FRAME = 15  # hostile messages after each good frame: 300 over a 20-frame run


def feed_hostile(
    harness: Any,
    rng: np.random.Generator,
    sources: Sequence[HostileSource],
    last_good_ns: int,
    frame_ns: int,
    count: int = HOSTILE_PER_FRAME,
) -> None:
    """Feed `harness` (a NodeHarness) `count` hostile messages, each from a random source."""
    for _ in range(count):
        source = sources[int(rng.integers(len(sources)))]
        msg, _ = spoil(rng, source.make_good(last_good_ns), source.fields, last_good_ns, frame_ns)
        harness.feed(source.topic, msg)


def unreadable_image(rng: np.random.Generator, like: Any, stamp_ns: int | None) -> Any:
    """A copy of the Image `like` that cannot be read (an unknown encoding, too few bytes or a
    step shorter than a row), stamped `stamp_ns` (None: before zero)."""
    msg = copy.deepcopy(like)
    kind = int(rng.integers(3))
    if kind == 0:
        msg.encoding = "32FC1"
    elif kind == 1:
        msg.data = bytes(msg.data[: int(rng.integers(len(msg.data)))])
    else:
        msg.step = int(rng.integers(msg.step))
    if stamp_ns is None:
        msg.header.stamp.sec = -5
    else:
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 10**9)
    return msg


def assert_unchanged_by_hostile_messages(
    run: Callable[[bool], tuple[Any, dict[str, int]]], capfd: Any, counted_at_least: int
) -> Any:
    """The property every node's hostile test checks: `run(hostile)` -> (the answers to the good
    messages, the node's problem counts by cause). The answers with hostile messages mixed in are
    the clean run's, at least `counted_at_least` were counted, and no cause was logged twice.
    Returns the clean answers."""
    clean, _ = run(False)
    capfd.readouterr()
    hostile, causes = run(True)
    assert hostile == clean
    warnings = warning_lines(capfd.readouterr().err)
    assert sum(causes.values()) >= counted_at_least, causes
    assert len(warnings) <= len(causes), "\n".join(warnings)
    return clean


def all_finite(values: Sequence[float]) -> bool:
    return all(math.isfinite(v) for v in values)


def warning_lines(stderr: str) -> list[str]:
    """The WARN / ERROR / FATAL log lines of a captured stderr."""
    return [line for line in stderr.splitlines() if re.match(r"\[(WARN|ERROR|FATAL)\]", line)]


def record_publishes(publisher: Any) -> list[Any]:
    """Every message `publisher` publishes from now on, recorded as the node publishes it (so a
    test reads a node's answer as soon as its callback returns, with no wait on delivery)."""
    published: list[Any] = []
    publish = publisher.publish

    def recording(msg: Any) -> None:
        published.append(msg)
        publish(msg)

    publisher.publish = recording
    return published
