"""Faults in the running graph: a restarted video_source, nodes dying under the demo runner (with
and without --respawn), and Ctrl-C to the runner. The run always ends with its bag closed and
its summary and tracks written, and says whether it is complete."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest
from demo_runs import with_logs
from ros_process import executable

pytestmark = [pytest.mark.ros, pytest.mark.slow]


@pytest.fixture(scope="module")
def walker(tmp_path_factory):
    """One object walking for 120 frames (12 s at 10 fps) on a 480x360 scene."""
    from tracker_ptz_sim.simulation.scene_files import write_scene
    from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

    root = tmp_path_factory.mktemp("walker")
    config = SceneConfig(
        width=480,
        height=360,
        num_frames=120,
        num_objects=1,
        object_size_range=(30, 50),
        speed_range=(25.0, 35.0),
        seed=4,
    )
    scene = generate_scene(config)
    return scene, write_scene(scene, root / "scene")


def killer(name, at_frame, sig=signal.SIGKILL):
    """A `during` callback that sends `sig` to a node once `at_frame` frames went out; the node
    stays watched, so the runner sees it die as it would see a crash."""
    done = {}

    def during(status, nodes):
        if done or status is None or status.frames_published < at_frame:
            return
        os.killpg(nodes.processes[name].pid, sig)
        done["frame"] = status.frames_published

    return during, done


def run(paths, out, during=None, respawn_limit=0, **overrides):
    from tracker_ptz_sim.bringup import demo
    from tracker_ptz_sim.bringup.graph import load_graph

    settings = {"video_source": {"rate": 0.0}, **overrides}
    return demo.run_graph(
        load_graph(),
        paths.video,
        out,
        settings,
        demo.install_space(),
        timeout=240.0,
        options=demo.RunOptions(
            during=during,
            respawn_limit=respawn_limit,
            shared_memory=False,  # nodes are killed here (config/fastdds_udp.xml)
        ),
    )


def stamps_of(bag, topic):
    from tracker_msgs_py.codec import stamp_to_ns
    from tracker_ptz_sim.evaluation.recording import read_bag

    return [stamp_to_ns(msg.header.stamp) for _, _, msg in read_bag(bag, {topic})]


def test_a_restarted_video_source_starts_a_new_epoch_the_graph_accepts(walker, tmp_path):
    """Killed and started again as launch's respawn would (from frame 0, so its stamps go back):
    every node takes the new epoch, and the whole stream goes through the graph again."""
    scene, paths = walker
    events = {}

    def during(status, nodes):
        if status is None:
            return
        if "killed" not in events and status.frames_published >= 40:
            nodes.kill("video_source")
            events["killed"] = status.frames_published
        elif "killed" in events and "restarted" not in events:
            events["restarted"] = nodes.start(
                "video_source",
                {"path": str(paths.video), "wait_for_subscribers": 2, "rate": 0.0},
            )

    result = run(paths, tmp_path, during=during)
    assert result.complete, with_logs(result, tmp_path)
    assert result.replay["frames_published"] == scene.num_frames  # the second source's status
    commands = stamps_of(result.bag, "/ptz/command")
    jump = next(i for i in range(1, len(commands)) if commands[i] < commands[i - 1])
    assert commands[jump] == 0  # the new epoch starts at the first frame again...
    new_epoch = commands[jump:]
    # ... and every one of its frames is answered, in order: no node drops it as stale.
    assert new_epoch == sorted(new_epoch) and len(new_epoch) == scene.num_frames
    detections = stamps_of(result.bag, "/detections")
    assert detections[-1] == new_epoch[-1]
    logs = (tmp_path / "logs" / "ptz_camera.log").read_text()
    assert "new replay epoch" in logs and "dropped a scene image" not in logs


def test_a_dying_node_ends_the_run_with_an_account_of_it(walker, tmp_path):
    scene, paths = walker
    during, killed = killer("tracker", at_frame=30)
    result = run(paths, tmp_path, during=during)
    assert killed and not result.complete
    assert len(result.problems) == 1
    assert re.fullmatch(
        r"tracker was killed by SIGKILL after frame (\d+) \(see logs/tracker.log\)",
        result.problems[0],
    )
    assert 0 < result.replay["frames_published"] < scene.num_frames
    # What was recorded is still a readable bag.
    assert len(stamps_of(result.bag, "/tracks")) >= killed["frame"] - 1


def test_respawn_restarts_dying_nodes_and_completes_the_run(walker, tmp_path):
    scene, paths = walker
    kill_detector, detector_killed = killer("ssim_detector", at_frame=20)
    kill_source, source_killed = killer("video_source", at_frame=60)

    def during(status, nodes):
        kill_detector(status, nodes)
        kill_source(status, nodes)

    result = run(paths, tmp_path, during=during, respawn_limit=3)
    assert detector_killed and source_killed
    assert result.complete, with_logs(result, tmp_path)
    assert result.restarts == {"ssim_detector": 1, "video_source": 1}
    # The restarted source resumed after its last frame: the frames in order, none twice but
    # for lockstep re-sends (which every node drops), at most the one in flight lost. Counted in
    # the camera's images (ptz_camera lives on): the recorder trails the lockstep graph, and the
    # frames a killed source sent but had not yet delivered to it are gone with the process.
    camera_stamps = stamps_of(result.bag, "/camera/image_raw")
    assert camera_stamps == sorted(camera_stamps)
    assert len(set(camera_stamps)) >= scene.num_frames - 1
    tracks = stamps_of(result.bag, "/tracks")
    assert tracks[-1] == camera_stamps[-1]  # tracking went on to the end


def run_demo_process(paths, out, *extra):
    command = [
        str(executable("tracker_ptz_sim", "run_demo")),
        "--video",
        str(paths.video),
        "--out",
        str(out),
        "--no-video",
        "--set",
        "video_source.rate=0.5",  # 24 s: room to act while it runs
        *extra,
    ]
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_for_frames(out, count, process, timeout=60.0):
    """Until the runner's video_source has published `count` frames (from its log)."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and process.poll() is None:
        log = out / "logs" / "ptz_camera.log"
        if log.exists() and "scene" in log.read_text():
            time.sleep(count / 5.0)  # rate 0.5 x 10 fps
            return
        time.sleep(0.1)
    raise AssertionError("the graph did not start")


def node_pid(runner_pid, name):
    """The process of the node named `name` (its __node remapping) started by the runner."""
    for child in os.listdir("/proc"):
        if not child.isdigit():
            continue
        try:
            stat = Path(f"/proc/{child}/stat").read_text()
            cmdline = Path(f"/proc/{child}/cmdline").read_text()
        except OSError:
            continue
        if int(stat.rsplit(")", 1)[1].split()[1]) == runner_pid and f"__node:={name}\0" in cmdline:
            return int(child)
    raise AssertionError(f"no {name} process under the runner")


def test_run_demo_reports_a_killed_node_and_writes_what_was_recorded(walker, tmp_path):
    _, paths = walker
    process = run_demo_process(paths, tmp_path)
    try:
        wait_for_frames(tmp_path, 20, process)
        os.kill(node_pid(process.pid, "ssim_detector"), signal.SIGKILL)
        stdout, stderr = process.communicate(timeout=120)
    finally:  # never leave a graph running into the next test's DDS domain
        if process.poll() is None:
            process.send_signal(signal.SIGINT)
            process.wait(timeout=30)
    assert process.returncode == 1, stdout + stderr
    assert "Traceback" not in stderr
    assert "ssim_detector was killed by SIGKILL" in stderr and "its last log lines" in stderr
    assert "INCOMPLETE" in stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["run"]["complete"] is False and summary["frames"] > 0
    assert "ssim_detector was killed by SIGKILL" in summary["run"]["problems"][0]
    assert (tmp_path / "tracks.txt").exists()


def test_run_demo_stops_on_ctrl_c_and_writes_what_was_recorded(walker, tmp_path):
    _, paths = walker
    process = run_demo_process(paths, tmp_path)
    wait_for_frames(tmp_path, 20, process)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=60)
    assert process.returncode == 130, stdout + stderr
    assert "Traceback" not in stderr and "interrupted by SIGINT" in stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["run"]["interrupted_by"] == "SIGINT" and summary["frames"] > 0
    assert summary["run"]["exit_codes"] and set(summary["run"]["exit_codes"].values()) == {0}
