"""An IP PTZ camera of the tests' own, run as its own process: the ONVIF test camera's head
(tests/onvif_camera.py) looking at a recorded scene, its view rewritten at the scene's frame rate
into one JPEG (a pinhole camera's image of the view, as a real camera's lens takes it) that
scripts/rtsp_server.py --latest streams. Together they are what a surveillance
camera is to the graph: RTSP video whose view moves where ONVIF commands take the head.

    python tests/ip_ptz_camera.py SCENE_DIR --view VIEW.jpg --log LOG.json \
        --view-size 168 --focal 280 --start-pan -0.3 [--never-idle] [--no-fov-moves]

The head's generic range [-1, 1] spans exactly the pans and tilts that keep the view inside the
scene (`pan_range` / `tilt_range` printed at start, for onvif_ptz). The scene's clip starts with
the first move request (the graph is up and steering by then) and plays once, one frame per
1/fps s of wall time; the last frame then stays. Every rendered frame's scene window is logged;
LOG.json is written when the clip has played (and again at SIGTERM). Prints
"ready PORT PAN_MIN PAN_MAX TILT_MIN TILT_MAX" once the ONVIF services listen, "started" when
the clip starts and "played" when it has played.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import signal
import sys
import threading
import time
from pathlib import Path

import cv2
from onvif_camera import OnvifCamera

from tracker_detect.pinhole import pinhole_view
from tracker_msgs_py.geometry import SceneGeometry
from tracker_ptz_sim.simulation.scene_files import load_scene

MOVES = {"ContinuousMove", "AbsoluteMove", "RelativeMove", "Stop", "GotoPreset"}


class HeadView:
    """Where the head looks, in scene pixels: generic x, y in [-1, 1] <-> pan, tilt <-> window."""

    def __init__(self, width: int, height: int, view: int, focal: float) -> None:
        self.geometry = SceneGeometry(width, height, focal)
        self.view = view
        self.pan_span = (width / 2.0 - view / 2.0) / focal  # rad either side of the middle
        self.tilt_span = (height / 2.0 - view / 2.0) / focal

    @property
    def ranges(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """onvif_ptz's pan_range and tilt_range: REP-103 angles at generic -1 and +1 (x + =
        right, so pan falls; y + = up, so tilt, + = down, falls)."""
        return (self.pan_span, -self.pan_span), (self.tilt_span, -self.tilt_span)

    def generic(self, pan: float, tilt: float) -> tuple[float, float]:
        return -pan / self.pan_span, -tilt / self.tilt_span

    def window(self, x: float, y: float) -> tuple[int, int, int, int]:
        """The scene rectangle (x0, y0, w, h) the head at generic (x, y) sees."""
        cx, cy = self.geometry.angles_to_pixel(-x * self.pan_span, -y * self.tilt_span)
        x0 = min(max(int(round(cx - self.view / 2.0)), 0), self.geometry.width - self.view)
        y0 = min(max(int(round(cy - self.view / 2.0)), 0), self.geometry.height - self.view)
        return x0, y0, self.view, self.view


def _write_atomically(path: Path, data: bytes) -> None:
    partial = path.with_suffix(".part")
    partial.write_bytes(data)
    os.replace(partial, path)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scene", type=Path)
    parser.add_argument("--view", type=Path, required=True, help="the JPEG the server streams")
    parser.add_argument("--log", type=Path, required=True)
    parser.add_argument("--view-size", type=int, default=168, help="px, square view")
    parser.add_argument("--focal", type=float, default=280.0, help="scene px per rad")
    parser.add_argument("--start-pan", type=float, default=0.0)
    parser.add_argument("--start-tilt", type=float, default=0.0)
    parser.add_argument("--top-speed", type=float, default=1.0, help="generic units/s")
    parser.add_argument("--never-idle", action="store_true")
    parser.add_argument("--no-fov-moves", action="store_true")
    args = parser.parse_args()

    scene = load_scene(args.scene)
    frames, fps = scene.frames, scene.fps
    height, width = frames.shape[1:3]
    head_view = HeadView(width, height, args.view_size, args.focal)
    camera = OnvifCamera(
        never_idle=args.never_idle,
        fov_moves=not args.no_fov_moves,
        top_speed=(args.top_speed, args.top_speed),
    )
    camera.head.x, camera.head.y = head_view.generic(args.start_pan, args.start_tilt)
    camera.presets["home"] = (camera.head.x, camera.head.y)
    spans = (2.0 * args.focal * math.atan(args.view_size / (2.0 * args.focal)),) * 2
    rendered: list[dict[str, float | int]] = []
    stop = threading.Event()

    def write_log() -> None:
        _write_atomically(args.log, json.dumps({"fps": fps, "frames": rendered}).encode())

    def render(index: int, logged: bool) -> None:
        x, y = camera.pose()
        x0, y0, w, h = head_view.window(x, y)
        view = pinhole_view(frames[index][y0 : y0 + h, x0 : x0 + w], (w, h), spans, args.focal)
        ok, jpeg = cv2.imencode(".jpg", view, [cv2.IMWRITE_JPEG_QUALITY, 90])
        if ok:
            _write_atomically(args.view, jpeg.tobytes())
        if logged:
            entry = {"frame": index, "time": time.time(), "x": x0, "y": y0, "w": w, "h": h}
            rendered.append(entry)

    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    with camera:
        render(0, logged=False)
        (pan_min, pan_max), (tilt_min, tilt_max) = head_view.ranges
        print(f"ready {camera.port} {pan_min} {pan_max} {tilt_min} {tilt_max}", flush=True)
        started: float | None = None
        shown = -1
        while not stop.is_set():
            if started is None and any(op in MOVES for op, _ in list(camera.requests)):
                started = time.monotonic()
                print("started", flush=True)
            if started is not None:
                index = min(int((time.monotonic() - started) * fps), len(frames) - 1)
                if index != shown:
                    render(index, logged=True)
                    shown = index
                    if index == len(frames) - 1:
                        write_log()
                        print("played", flush=True)
            stop.wait(1.0 / (4 * fps))  # a frame's view is the head's pose when it is due
    write_log()
    return 0


if __name__ == "__main__":
    sys.exit(main())
