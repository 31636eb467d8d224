"""The surveillance graph on an IP PTZ camera, end to end through both protocols: the launch file
with camera:=live unit:=onvif reads RTSP video from the local GStreamer server and steers the
tests' ONVIF camera, whose head decides what that video shows (tests/ip_ptz_camera.py). The
walker is followed about as closely as by the simulated camera on the same clip, on a camera
without FOV moves whose MoveStatus never returns to idle, and again after the stream drops."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
import yaml
from demo_runs import ONE_WALKER, VIEW_FRACTION, run_demo
from ros_process import RosProcess
from rtsp_camera import RtspCamera, require_gstreamer

pytestmark = [pytest.mark.ros, pytest.mark.slow]

CAMERA = Path(__file__).resolve().parents[1] / "ip_ptz_camera.py"
WALKER_PAN = -0.3  # rad: both cameras start pointed at the walker (the standard-graph test's)
VIEW = 168  # px: the simulated camera's view on the 640x480 scene (VIEW_FRACTION)
FOCAL = 280.0  # scene px per rad: that view's 0.6 rad field of view
#: This is about following: both cameras are homed where they start (no target: the controller
#: goes home; a user's home preset is where the camera should watch) and do not sweep in search.
FOLLOWING = {"search": "none", "home": [WALKER_PAN, 0.0]}


def _scene(root: Path):
    from tracker_ptz_sim.simulation.scene_files import write_scene
    from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

    return write_scene(generate_scene(SceneConfig(**ONE_WALKER)), root / "scene")


def _follow(gt: Path, windows):
    """follow_scores over every frame from the first that shows the walker (both cameras start
    pointed at it), the same for the simulated and the IP camera."""
    from tracker_ptz_sim.evaluation import metrics

    truth = metrics.load_mot(gt)
    shown = {
        frame: truth[frame][1].center
        for frame, window in windows.items()
        if 1 in truth.get(frame, {}) and window.contains(*truth[frame][1].center)
    }
    return metrics.follow_scores(truth, windows, {min(shown): shown[min(shown)]})


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return _scene(tmp_path_factory.mktemp("onvif_scene"))


@pytest.fixture(scope="module")
def simulated(scene, tmp_path_factory):
    """The simulated camera (ptz_camera, lockstep) on the clip: the figure to be close to."""
    from tracker_ptz_sim.evaluation import run_report
    from tracker_ptz_sim.evaluation.scoring import windows_and_targets

    assert abs(VIEW_FRACTION * 480 - VIEW) < 1
    out = tmp_path_factory.mktemp("onvif_simulated") / "run"
    settings = [f"ptz_controller.{k}={v}" for k, v in FOLLOWING.items()]
    run_demo(scene.video, out, f"ptz_camera.initial_pan={WALKER_PAN}", *settings)
    windows, _ = windows_and_targets(run_report.collect(out / "bag"))
    return _follow(scene.gt, windows)


class IpCamera:
    """tests/ip_ptz_camera.py in its own process (the ONVIF services and the view it renders)
    plus the RTSP server streaming that view."""

    def __init__(self, scene_root: Path, folder: Path, *quirks: str) -> None:
        folder.mkdir(parents=True, exist_ok=True)
        self.log = folder / "camera.json"
        view = folder / "view.jpg"
        command = [sys.executable, str(CAMERA), str(scene_root), "--view", str(view)]
        command += ["--log", str(self.log), "--view-size", str(VIEW), "--focal", str(FOCAL)]
        command += ["--start-pan", str(WALKER_PAN), *quirks]
        self.process = subprocess.Popen(command, stdout=subprocess.PIPE, text=True)
        ready = self.process.stdout.readline().split() if self.process.stdout else []
        assert ready and ready[0] == "ready", f"the test camera did not start: {ready}"
        self.port = int(ready[1])
        pan_min, pan_max, tilt_min, tilt_max = (float(v) for v in ready[2:6])
        self.pan_range, self.tilt_range = [pan_min, pan_max], [tilt_min, tilt_max]
        self.rtsp = RtspCamera(view, fps=10, latest=True).start()

    def params(self) -> dict:
        """What a user writes in their params file for this camera."""
        top = [abs(self.pan_range[0]), abs(self.tilt_range[0])]  # velocity 1: 1 generic unit/s
        return {
            "/**/onvif_ptz": {
                "ros__parameters": {
                    "host": "127.0.0.1",
                    "port": self.port,
                    "pan_range": self.pan_range,
                    "tilt_range": self.tilt_range,
                    "top_rates": top,
                }
            },
            "/**/video_source": {"ros__parameters": {"focal_length": FOCAL}},
            "/**/ptz_state_bridge": {
                "ros__parameters": {
                    "scene_width": 640,
                    "scene_height": 480,
                    "scene_focal_length": FOCAL,
                }
            },
            "/**/ptz_controller": {"ros__parameters": dict(FOLLOWING)},
        }

    def played(self) -> bool:
        return self.log.exists()

    def windows(self, since: float = 0.0):
        """The scene window of each clip frame (MOT numbers, from 1) rendered after `since`
        (wall clock)."""
        from tracker_msgs_py.geometry import Rect

        rendered = json.loads(self.log.read_text())["frames"]
        return {
            r["frame"] + 1: Rect(r["x"], r["y"], r["w"], r["h"])
            for r in rendered
            if r["time"] >= since
        }

    def close(self) -> None:
        self.rtsp.stop()
        self.process.terminate()
        self.process.wait(timeout=10)


def _follow_on_ip_camera(scene, folder: Path, *quirks: str, during=None):
    """The launch file's graph on an IP camera until the clip has played, `during(camera)`
    running meanwhile in a thread of its own: (the camera, the graph's output)."""
    require_gstreamer()
    camera = IpCamera(scene.root, folder, *quirks)
    mine = folder / "my_camera.yaml"
    mine.write_text(yaml.safe_dump(camera.params()))
    runner = RosProcess(
        "tracker_ptz_sim",
        "run_launch",
        "tracker_ptz_sim",
        "surveillance.launch.py",
        "camera:=live",
        "unit:=onvif",
        "graph:=motion",
        f"video:={camera.rtsp.url}",
        f"params_file:={mine}",
        log_dir=folder / "logs",
    )
    side = threading.Thread(target=during, args=(camera,)) if during else None
    try:
        if side is not None:
            side.start()
        deadline = time.monotonic() + 120.0
        while not camera.played() and time.monotonic() < deadline:
            assert runner.process.poll() is None, runner.output()[-4000:]
            time.sleep(0.2)
        assert camera.played(), runner.output()[-4000:]
        assert runner.interrupt(timeout=20.0) == 0, runner.output()[-4000:]
        return camera, runner.output()
    finally:
        if side is not None:
            side.join(30.0)
        runner.kill()
        camera.close()


def test_the_graph_follows_a_walker_through_rtsp_and_onvif(scene, simulated, tmp_path):
    camera, output = _follow_on_ip_camera(scene, tmp_path, "--never-idle", "--no-fov-moves")
    follow = _follow(scene.gt, camera.windows())
    print(f"IP camera {follow}\nsimulated {simulated}")
    assert "ONVIF camera 127.0.0.1" in output, output[-3000:]
    assert follow.followed_id == 1 and follow.frames_after_lock >= 140, follow
    assert follow.inside_share >= 0.95, follow
    assert follow.mean_center_error_px <= 1.5 * simulated.mean_center_error_px, (follow, simulated)


OUTAGE_AFTER_S = 4.0  # s into the clip: the camera is following by then
OUTAGE_S = 1.0  # a network blip: the walker is still in view when the stream returns


def test_the_walker_is_followed_again_after_the_stream_drops(scene, tmp_path):
    """The RTSP server stops for 1 s while the camera follows: the camera holds still (no
    images, no commands: the ContinuousMove times out), the stream comes back (about 2 s after it
    went), the controller holds while the tracker takes the walker up again, and follows it."""
    back: list[float] = []

    def drop_once(camera: IpCamera) -> None:
        while camera.process.stdout and camera.process.stdout.readline().strip() != "started":
            pass
        time.sleep(OUTAGE_AFTER_S)
        camera.rtsp.stop()
        time.sleep(OUTAGE_S)
        camera.rtsp.start()
        back.append(time.time())

    camera, output = _follow_on_ip_camera(scene, tmp_path, during=drop_once)
    assert "stream lost" in output and "stream back" in output, output[-3000:]
    after = _follow(scene.gt, camera.windows(since=back[0] + 3.0))
    print(f"after the outage {after}\nwhole clip {_follow(scene.gt, camera.windows())}")
    assert after.frames_after_lock >= 40 and after.inside_share >= 0.9, after
