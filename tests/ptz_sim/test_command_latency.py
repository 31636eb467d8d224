"""The camera's own image-to-command latency (tracker_ptz_sim.simulation.command_latency)."""

from __future__ import annotations

import pytest

from tracker_ptz_sim.simulation.command_latency import (
    CommandLatency,
    diagnostics_values,
    from_diagnostics,
)

MS = 1_000_000


def test_each_command_times_the_image_of_its_stamp_once():
    latency = CommandLatency()
    latency.image_sent(100, 0)
    latency.image_sent(200, 5 * MS)
    assert latency.command_received(200, 12 * MS) == 7.0  # out of order: by stamp
    assert latency.command_received(100, 20 * MS) == 20.0
    assert latency.command_received(100, 30 * MS) is None  # a second command for it
    assert latency.command_received(300, 30 * MS) is None  # no such image
    assert len(latency) == 2
    assert latency.stats() == {"p50": 13.5, "p95": pytest.approx(19.35), "max": 20.0}


def test_images_never_answered_are_forgotten_beyond_the_limit_and_at_a_new_epoch():
    latency = CommandLatency(pending_limit=2)
    for k in range(3):
        latency.image_sent(k, k * MS)
    assert latency.command_received(0, 10 * MS) is None  # the oldest was dropped
    assert latency.command_received(2, 10 * MS) == 8.0
    latency.forget_pending()
    assert latency.command_received(1, 10 * MS) is None
    assert len(latency) == 1 and CommandLatency().stats() == {}
    with pytest.raises(ValueError):
        CommandLatency(pending_limit=0)


def test_the_figures_read_back_from_the_diagnostics():
    latency = CommandLatency()
    assert diagnostics_values(latency) == {}
    for k in range(10):
        latency.image_sent(k, 0)
        latency.command_received(k, (k + 1) * MS)
    values = diagnostics_values(latency) | {
        "other key": "x",
        "camera image to command p50 [ms]x": "y",
    }
    read = from_diagnostics(values.items())
    assert read == {"p50": 5.5, "p95": pytest.approx(9.55, abs=0.01), "max": 10.0, "count": 10.0}
