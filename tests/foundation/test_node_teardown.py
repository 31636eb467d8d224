"""run_node's teardown deadline: a node whose middleware teardown blocks (as rclpy's node destruction
was seen to, holding the interpreter lock) still exits with its code within 2 s of the stop, its
stacks in the log."""

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
import ctypes, sys, time
from tracker_msgs_py.node_main import SuiteNode, run_node

class StuckInTeardown(SuiteNode):
    def __init__(self, **options):
        super().__init__("stuck_in_teardown", **options)
        self.create_timer(0.05, self._ready)

    def _ready(self):
        print("ready", flush=True)

    def destroy_node(self):
        BLOCK  # stands for the middleware blocking inside rclpy's node destruction

sys.exit(run_node(StuckInTeardown, []))
"""


BLOCKS = {
    "releasing the interpreter lock": "time.sleep(30)",
    # a C call through PyDLL keeps the lock, as pybind11's rcl_node_fini binding does
    "holding the interpreter lock": "ctypes.PyDLL(None).sleep(30)",
}


@pytest.mark.parametrize("block", BLOCKS.values(), ids=BLOCKS.keys())
def test_a_teardown_that_blocks_ends_at_the_deadline_with_the_nodes_code(block):
    process = subprocess.Popen(
        [sys.executable, "-c", NODE.replace("BLOCK", block)],
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
    assert "Timeout" in stderr  # faulthandler's header, then the stacks
    assert "in destroy_node" in stderr
