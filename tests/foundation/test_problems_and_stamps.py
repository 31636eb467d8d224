"""The shared bad-input reporting (one warning per cause, then counts) and stamp order / epochs."""

from __future__ import annotations

from tracker_msgs_py.problems import ProblemLog
from tracker_msgs_py.stamps import Order, StampOrder


def test_one_warning_per_distinct_cause_then_counts():
    lines: list[str] = []
    log = ProblemLog(lines.append)
    assert log.report("non-finite command", "inf rate")
    assert not log.report("non-finite command", "another inf rate")
    assert log.report("unknown command mode", "mode 7")  # a new cause is not hidden by the first
    log.report("non-finite command", "again", count=3)
    assert len(lines) == 2 and "inf rate" in lines[0] and "mode 7" in lines[1]
    assert all("further ones are counted" in line for line in lines)
    assert log.counts == {"non-finite command": 5, "unknown command mode": 1}
    assert log.total == 6 and log.count("nothing") == 0
    assert log.summary() == "5 x non-finite command, 1 x unknown command mode"


def test_stamps_next_repeat_invalid_and_new_epochs():
    order = StampOrder()
    assert [order.check(s) for s in (10, 20, 20, 30)] == [
        Order.NEXT,
        Order.NEXT,
        Order.REPEAT,
        Order.NEXT,
    ]
    assert order.check(-5) is Order.INVALID and order.last_ns == 30
    assert order.check(5) is Order.NEW_EPOCH and order.epochs == 1
    assert "jumped back 0.000 s" in order.describe_jump()
    assert order.check(5) is Order.REPEAT  # a repeat right after the jump is still a repeat
    assert order.check(6) is Order.NEXT
    order.reset()
    assert order.check(1) is Order.NEXT and order.epochs == 1


def test_a_leap_ahead_longer_than_the_stream_allows_is_a_new_epoch():
    s = 10**9
    order = StampOrder(max_gap_ns=s)
    assert [order.check(t) for t in (0, s // 10, s + s // 10)] == [Order.NEXT] * 3
    assert order.check(6 * s + s // 10) is Order.NEW_EPOCH and order.epochs == 1
    assert "jumped ahead 5.000 s, to 6.100 s" in order.describe_jump()
    assert order.check(6 * s + s // 5) is Order.NEXT
    assert StampOrder().check(10**18) is Order.NEXT  # without a limit, no leap is too long
