"""run_node's teardown deadline: a node whose middleware teardown blocks (as Fast DDS's participant
deletion was seen to) still exits with its code within 2 s of the stop, saying why."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

pytest.importorskip("rclpy")
pytestmark = pytest.mark.ros

NODE = """
import sys, time
from tracker_msgs_py.node_main import SuiteNode, run_node

class StuckInTeardown(SuiteNode):
    def __init__(self, **options):
        super().__init__("stuck_in_teardown", **options)
        self.create_timer(0.05, self._ready)

    def _ready(self):
        print("ready", flush=True)

    def destroy_node(self):
        time.sleep(30)  # stands for rcl_node_fini blocking in the middleware

sys.exit(run_node(StuckInTeardown, []))
"""


def test_a_teardown_that_blocks_ends_at_the_deadline_with_the_nodes_code():
    process = subprocess.Popen(
        [sys.executable, "-c", NODE],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ),
    )
    try:
        assert process.stdout.readline() == "ready\n"
        process.send_signal(signal.SIGINT)
        stopped = time.monotonic()
        code = process.wait(timeout=10)
        elapsed = time.monotonic() - stopped
    finally:
        process.kill()
        _, stderr = process.communicate(timeout=10)
    assert code == 0, stderr
    assert elapsed < 2.0
    assert "teardown did not finish within 1.8 s" in stderr
