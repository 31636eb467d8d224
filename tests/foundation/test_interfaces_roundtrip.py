"""Every tracker_msgs message and service round-trips across two processes over DDS."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tracker_msgs_py import stop_signals

PEER = Path(__file__).with_name("interface_peer.py")
EXPECTED = {
    "Rect",
    "SelectRegion",
    "Blob",
    "BlobArray",
    "Track",
    "TrackArray",
    "Target",
    "PtzState",
    "PtzCommand",
    "ReplayStatus",
    "SelectTarget",
    "ResetTracker",
}

pytestmark = pytest.mark.ros


def test_every_interface_round_trips_between_processes(tmp_path):
    server = subprocess.Popen(
        [sys.executable, str(PEER), "serve"],
        env=dict(os.environ),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    try:
        probe = subprocess.run(
            [sys.executable, str(PEER), "probe"],
            env=dict(os.environ),
            capture_output=True,
            text=True,
            timeout=120,
        )
    finally:
        server.terminate()
        try:
            server.wait(timeout=10)
        except subprocess.TimeoutExpired:
            server.send_signal(stop_signals.STACK_DUMP_SIGNAL)
            time.sleep(0.5)
            server.kill()
            stacks = server.communicate()[0]
            raise AssertionError(
                f"the echo server ignored SIGTERM; its output:\n{stacks}"
            ) from None
        assert server.returncode == 0, server.communicate()[0]
    assert probe.stdout.strip(), f"probe printed nothing; stderr:\n{probe.stderr}"
    report = json.loads(probe.stdout.strip().splitlines()[-1])
    assert set(report) == EXPECTED, "an interface was added or removed: update EXPECTED"
    failures = {name: result for name, result in report.items() if result != "ok"}
    assert not failures, failures
    assert probe.returncode == 0


def test_populated_values_are_distinctive():
    """The filler really sets non-default values, so an unset field on the wire would be caught."""
    sys.path.insert(0, str(PEER.parent))
    import interface_peer

    import tracker_msgs.msg as msgs

    track = interface_peer.populated(msgs.Track, 5)
    assert track.id == 2**32 - 1 - (5 * 31 + 1)
    assert track.state_layout and len(track.state) == 3 and len(track.position_covariance) == 4
    assert track.bbox.width != 0.0
    array_msg = interface_peer.populated(msgs.BlobArray, 2)
    assert len(array_msg.blobs) == 3 and array_msg.header.frame_id
    assert interface_peer.as_plain(array_msg) != interface_peer.as_plain(msgs.BlobArray())
