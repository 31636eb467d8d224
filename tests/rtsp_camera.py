"""A local RTSP camera for the tests: scripts/rtsp_server.py (GStreamer's RTSP server on the system
Python) streaming a folder of JPEG frames, which a test can stop and start again mid-stream."""

from __future__ import annotations

import os
import socket
import subprocess
from pathlib import Path

import cv2
import pytest

SERVER = Path(__file__).resolve().parents[1] / "scripts" / "rtsp_server.py"
SYSTEM_PYTHON = "/usr/bin/python3"


def require_gstreamer() -> None:
    """Skip when the RTSP server cannot run here, except under CI (which installs it)."""
    check = [SYSTEM_PYTHON, "-c", "import gi; gi.require_version('GstRtspServer', '1.0')"]
    try:
        ok = subprocess.run(check, capture_output=True, timeout=30).returncode == 0
    except OSError:
        ok = False
    if not ok:
        message = "GStreamer's RTSP server is not installed (bash scripts/install_rtsp_server.sh)"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def write_jpegs(frames, folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    for index, image in enumerate(frames):
        cv2.imwrite(str(folder / f"{index:05d}.jpg"), image, [cv2.IMWRITE_JPEG_QUALITY, 90])
    return folder


class RtspCamera:
    """The server on `port`, serving `frames` at `fps` on /live (with `user`/`password`: Basic
    authentication). `url` has the credentials in it."""

    def __init__(
        self, frames: Path, fps: int = 10, user: str = "", password: str = "", latest: bool = False
    ) -> None:
        """`latest`: `frames` is one .jpg, sent as it is whenever a frame is due."""
        self.port = free_port()
        source = ["--latest", str(frames)] if latest else [str(frames)]
        self.command = [SYSTEM_PYTHON, str(SERVER), *source, "--port", str(self.port)]
        self.command += ["--fps", str(fps)]
        if user:
            self.command += ["--user", user, "--password", password]
        credentials = f"{user}:{password}@" if user else ""
        self.url = f"rtsp://{credentials}127.0.0.1:{self.port}/live"
        self.process: subprocess.Popen | None = None

    def start(self) -> RtspCamera:
        self.process = subprocess.Popen(
            self.command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
        line = self.process.stdout.readline() if self.process.stdout else ""
        if not line.startswith("ready"):
            error = self.process.stderr.read() if self.process.stderr else ""
            raise RuntimeError(f"the RTSP server did not start: {line}{error}")
        return self

    def stop(self) -> None:
        if self.process is not None:
            self.process.terminate()
            self.process.wait(timeout=10)
            self.process = None

    def __enter__(self) -> RtspCamera:
        return self.start()

    def __exit__(self, *_exc: object) -> None:
        self.stop()
