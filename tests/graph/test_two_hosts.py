"""The graph split over two hosts (two network namespaces joined by a veth pair, DDS discovery on
the subnet): camera and detector on one, tracker and controller on the other. It runs, tracks
exactly as on one host, and the detector -> tracker hop's latency is measured by a probe on the
middleware's timestamps (scripts/two_hosts.py)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.ros, pytest.mark.slow]
ROOT = Path(__file__).resolve().parents[2]
HOP = "ssim_detector -> tracker"


def can_make_network_namespaces() -> bool:
    if os.geteuid() != 0:
        return False
    name = f"tsprobe{os.getpid() % 10000}"
    made = subprocess.run(["ip", "netns", "add", name], capture_output=True).returncode == 0
    subprocess.run(["ip", "netns", "del", name], capture_output=True)
    return made


@pytest.mark.skipif(not can_make_network_namespaces(), reason="needs root and ip netns")
def test_the_graph_split_over_two_hosts_tracks_as_on_one(tmp_path):
    from tracker_ptz_sim.simulation.scene_files import write_scene
    from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

    config = SceneConfig(width=640, height=480, num_frames=60, num_objects=1, seed=9)
    paths = write_scene(generate_scene(config), tmp_path / "scene")
    command = [sys.executable, str(ROOT / "scripts/two_hosts.py"), "--video", str(paths.video)]
    command += ["--out", str(tmp_path / "out")]
    result = subprocess.run(command, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads((tmp_path / "out/two_hosts.json").read_text())
    assert report["frames"] == [60, 60]
    assert report["same_tracks"]
    probed = report["probed_hop_ms"]
    for run in ("two hosts", "one host"):
        assert probed[run]["frames"] >= 55  # the probe starts before the graph's first frame
        # from the detections' publication to their target's arrival: causal, never negative
        assert 0 < probed[run]["min"] <= probed[run]["p50"] <= probed[run]["max"]
        assert HOP in report["latency_ms"][run]  # and the recorder's figure is reported beside
    assert report["hop_added_ms_p50"] == pytest.approx(
        probed["two hosts"]["p50"] - probed["one host"]["p50"]
    )
