"""A short run of the shutdown stress script: every node, signals at random moments of start-up
and work inside a running graph, exits 0 within 2 s. (`make stress` runs 50 per node.)"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.ros, pytest.mark.slow]
SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "stress_signals.py"
NODES = ("video_source", "ptz_camera", "ssim_detector", "tracker", "ptz_controller")


def test_a_short_stress_run_is_clean_for_every_node():
    result = subprocess.run(
        [sys.executable, str(SCRIPT), "--signals", "3", "--max-delay", "1.5", "--seed", "1"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    for node in NODES:
        assert f"{node:15s} exit codes {{0: 3}}" in result.stdout, result.stdout
    assert "all clean" in result.stdout
