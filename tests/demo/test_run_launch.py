"""run_launch: surveillance.launch.py itself on the wheels install (no launch / launch_ros): its
arguments, the commands it gives each node (as launch_ros would), and a real run of the graph
from the launch file that follows a walker to the end of the clip and stops on Ctrl-C."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from ros_process import RosProcess, executable

pytestmark = pytest.mark.ros
LAUNCH = ("tracker_ptz_sim", "surveillance.launch.py")


def run_launch(*arguments: str) -> subprocess.CompletedProcess:
    command = [str(executable("tracker_ptz_sim", "run_launch")), *arguments]
    return subprocess.run(command, capture_output=True, text=True, timeout=60)


def commands_by_node(printed: str) -> dict[str, str]:
    lines = [line for line in printed.splitlines() if "--ros-args" in line]
    return {line.split("__node:=")[1].split()[0]: line for line in lines}


def test_the_commands_carry_the_params_file_last_and_the_remaps(tmp_path):
    mine = tmp_path / "mine.yaml"
    mine.write_text(yaml.safe_dump({"/**/ptz_controller": {"ros__parameters": {"kp": 2.0}}}))
    printed = run_launch(
        "--print",
        *LAUNCH,
        "camera:=live",
        f"params_file:={mine}",
        "image_topic:=/axis/image_raw",
        "joint_states_topic:=/axis/joint_states",
    )
    assert printed.returncode == 0, printed.stderr
    commands = commands_by_node(printed.stdout)
    assert set(commands) == {
        "ptz_state_bridge",
        "ssim_detector",
        "tracker",
        "ptz_controller",
        "ptz_tf",
    }
    for command in commands.values():
        files = [part for part in command.split() if part.endswith(".yaml")]
        assert str(mine) in files and files.index(str(mine)) == len(files) - 2  # then the values
        assert "-r camera/image_raw:=/axis/image_raw" in command
        assert "-r ptz/joint_states:=/axis/joint_states" in command
    values = commands["ptz_controller"].split("--params-file ")[-1].split()[0]
    assert yaml.safe_load(Path(values).read_text()) == {
        "/ptz_controller": {"ros__parameters": {"use_sim_time": False}}
    }


def test_bad_arguments_are_one_fatal_line():
    for arguments, cause in [
        (("graph:=nope", "video:=v.avi"), "must be one of"),
        (("vidoe:=v.avi",), "unknown launch argument"),
        (("video:=v.avi", "params_file:=/no/such.yaml"), "no such file"),
        (("video",), "name:=value"),
    ]:
        result = run_launch(*LAUNCH, *arguments)
        assert (
            result.returncode == 2
            and "[FATAL] run_launch" in result.stderr
            and cause in (result.stderr)
        ), result.stderr


def walker_clip(folder, frames=30):
    """A dark square walking right over a textured background, 320x240 PNGs."""
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(5)
    background = cv2.GaussianBlur(rng.integers(0, 255, (240, 320, 3), np.uint8), (0, 0), 2)
    for k in range(frames):
        frame = background.copy()
        frame[120:170, 60 + 4 * k : 80 + 4 * k] = 20
        cv2.imwrite(str(folder / f"{k:04d}.png"), frame)
    return folder


def test_the_launch_file_runs_the_graph_to_the_end_of_the_clip_and_stops_on_ctrl_c(tmp_path):
    rclpy = pytest.importorskip("rclpy")
    from rclpy.executors import SingleThreadedExecutor

    from tracker_msgs.msg import PtzCommand, ReplayStatus
    from tracker_msgs_py.codec import command_qos
    from tracker_ptz_sim.simulation.video_source_node import STATUS_QOS

    clip = walker_clip(tmp_path / "clip")
    context = rclpy.Context()
    rclpy.init(context=context)
    watcher = rclpy.create_node("launch_watcher", context=context)
    commands, statuses = [], []
    watcher.create_subscription(PtzCommand, "/ptz/command", commands.append, command_qos())
    watcher.create_subscription(ReplayStatus, "/replay/status", statuses.append, STATUS_QOS)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(watcher)
    runner = RosProcess(
        "tracker_ptz_sim",
        "run_launch",
        *LAUNCH,
        "graph:=motion",
        f"video:={clip}",
        log_dir=tmp_path / "logs",
    )
    try:
        deadline = time.monotonic() + 90.0
        ended = lambda: any(s.state == ReplayStatus.STATE_ENDED for s in statuses)  # noqa: E731
        while not ended() and time.monotonic() < deadline and runner.process.poll() is None:
            executor.spin_once(timeout_sec=0.1)
        assert ended(), runner.output()[-3000:]
        # the clip's 30 frames answered (the first may precede this watcher's discovery)
        assert len({c.header.stamp.nanosec + 10**9 * c.header.stamp.sec for c in commands}) >= 10
        assert any(c.mode == PtzCommand.MODE_VELOCITY for c in commands)
        assert runner.interrupt(timeout=20.0) == 0, runner.output()[-3000:]
    finally:
        runner.kill()
        executor.shutdown()
        watcher.destroy_node()
        rclpy.shutdown(context=context)
