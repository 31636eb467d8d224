"""Every node executable starts from the install space and exits 0 within 2 s of SIGINT or SIGTERM
(the random-moment version is tests/foundation/test_stress_signals.py)."""

from __future__ import annotations

import signal
import time

import cv2
import numpy as np
import pytest
from ros_process import RosProcess, installed_executables

pytestmark = pytest.mark.ros

STARTUP_S = 2.5  # long enough for rclpy + OpenCV imports and node construction on this machine
SHUTDOWN_S = 2.0

# Command-line tools: run to completion, not nodes.
TOOLS = {
    "make_scene",
    "fetch_sample",
    "evaluate",
    "run_demo",
    "run_launch",  # a process runner (tests/demo/test_run_launch.py stops one with Ctrl-C)
    "benchmark",
    "predictor_study",
    "single_target_benchmark",
    "phd_benchmark",
    "voxel_benchmark",
    "annotate",
    "parameter_tables",  # a README generator: runs and exits
}


def _video(tmp_path):
    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (160, 120))
    rng = np.random.default_rng(0)
    for _ in range(20):
        writer.write(rng.integers(0, 255, (120, 160, 3), dtype=np.uint8))
    writer.release()
    return path


@pytest.fixture(scope="module")
def onvif_camera():
    """The camera onvif_ptz drives (the tests' ONVIF double), started once."""
    from onvif_camera import OnvifCamera

    with OnvifCamera() as camera:
        yield camera


def node_params(name: str, tmp_path, request) -> dict[str, object]:
    """Parameters a node needs to start at all (most need none)."""
    if name == "onvif_ptz":
        camera = request.getfixturevalue("onvif_camera")
        return {"host": "127.0.0.1", "port": camera.port}
    if name == "video_source":
        return {"path": str(_video(tmp_path)), "loop": True}
    if name == "live_view":
        # any free port: the default 8765 may be held by a running live view or another test run
        return {"port": 0}
    return {}


def node_executables() -> list[tuple[str, str]]:
    return [
        (package, name)
        for package, names in installed_executables().items()
        for name in names
        if name not in TOOLS
    ]


def test_the_suite_installs_node_executables():
    assert node_executables(), "no node executables installed: run 'make setup'"


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
@pytest.mark.parametrize(("package", "name"), node_executables())
def test_node_exits_cleanly_on_a_stop_signal(package, name, signum, tmp_path, request):
    params = node_params(name, tmp_path, request)
    node = RosProcess(package, name, log_dir=tmp_path, params=params)
    try:
        time.sleep(STARTUP_S)
        assert node.process.poll() is None, f"{name} died at start-up:\n{node.output()}"
        started = time.monotonic()
        code = node.interrupt(timeout=SHUTDOWN_S, signum=signum)
        elapsed = time.monotonic() - started
        assert code is not None, f"{name} still running {SHUTDOWN_S} s after {signum.name}"
        assert code == 0, f"{name} exited {code} after {signum.name}:\n{node.output()}"
        assert "Traceback" not in node.output()
        assert elapsed <= SHUTDOWN_S
    finally:
        node.kill()
