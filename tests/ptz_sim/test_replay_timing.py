"""Replay pacing (a rate change continues from now: no burst, no stall) and the read-ahead thread
(stopped and joined on close, errors handed to the consumer)."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from tracker_ptz_sim.simulation.frame_sources import Frame
from tracker_ptz_sim.simulation.replay import Pacer, Prefetcher

FRAME_NS = 100_000_000  # 10 fps


def schedule(pacer, stamps, now, changes=None):
    """Send times of frames sent as soon as they are due; `changes` {frame: new rate}."""
    sent = []
    for k, stamp in enumerate(stamps):
        if changes and k in changes:
            pacer.set_rate(changes[k], now)
        now += pacer.delay(stamp, now)
        pacer.sent(stamp)
        sent.append(now)
    return np.diff(sent)


def test_real_time_pacing():
    gaps = schedule(Pacer(1.0), [k * FRAME_NS for k in range(20)], now=100.0)
    np.testing.assert_allclose(gaps, 0.1)
    np.testing.assert_allclose(schedule(Pacer(2.0), [0, FRAME_NS], 0.0), [0.05])
    assert Pacer(0.0).delay(10 * FRAME_NS, 5.0) == 0.0  # as fast as possible


def test_speeding_up_late_in_a_replay_gives_no_burst():
    stamps = [k * FRAME_NS for k in range(60)]
    gaps = schedule(Pacer(1.0), stamps, 0.0, changes={50: 5.0})
    np.testing.assert_allclose(gaps[:49], 0.1)
    np.testing.assert_allclose(gaps[50:], 0.02)  # 5x from the change on, not a catch-up burst


def test_slowing_down_late_in_a_replay_gives_no_stall():
    stamps = [k * FRAME_NS for k in range(60)]
    gaps = schedule(Pacer(5.0), stamps, 0.0, changes={50: 1.0})
    assert gaps.max() == pytest.approx(0.1)


def test_a_change_while_waiting_reschedules_the_waiting_frame():
    pacer = Pacer(0.01)  # a frame every 10 s
    pacer.delay(0, 0.0)
    pacer.sent(0)
    assert pacer.delay(FRAME_NS, 0.5) == pytest.approx(9.5)
    pacer.set_rate(1.0, 0.5)
    assert pacer.delay(FRAME_NS, 0.5) == pytest.approx(0.1)


def frames(count, fail_at=None, delay=0.0):
    for k in range(count):
        if k == fail_at:
            raise OSError("disk gone")
        time.sleep(delay)
        yield Frame(k, k * FRAME_NS, np.full((2, 2, 3), k, np.uint8))


def test_prefetcher_yields_every_frame_in_order():
    reader = Prefetcher(frames(10))
    assert [f.index for f in reader] == list(range(10))
    assert reader.close()


def test_prefetcher_hands_errors_to_the_consumer():
    reader = Prefetcher(frames(10, fail_at=4))
    seen = []
    with pytest.raises(OSError, match="disk gone"):
        for frame in reader:
            seen.append(frame.index)
    assert seen == [0, 1, 2, 3] and reader.close()


def test_closing_stops_and_joins_the_reader_even_when_nobody_consumes():
    before = threading.active_count()
    reader = Prefetcher(frames(1000, delay=0.001), depth=2)
    iterator = iter(reader)
    assert next(iterator).index == 0
    started = time.monotonic()
    assert reader.close(timeout=1.0)
    assert time.monotonic() - started < 0.5
    assert list(iterator) == []  # a closed reader yields nothing more
    assert threading.active_count() == before
