"""Every node process spins rclpy's EventsExecutor unless `--executor` (before `--ros-args`) names
another; a name it does not know stops the process with one line naming the choices."""

from __future__ import annotations

import subprocess

import pytest
from ros_process import executable

pytest.importorskip("rclpy")

from tracker_msgs_py.node_main import DEFAULT_EXECUTOR, executor_argument  # noqa: E402


@pytest.mark.parametrize(
    "argv, expected",
    [
        (["video_source"], DEFAULT_EXECUTOR),
        (["video_source", "--ros-args", "-p", "rate:=2.0"], DEFAULT_EXECUTOR),
        (["video_source", "--executor", "single", "--ros-args", "-r", "__node:=x"], "single"),
        (["graph_host", "--graph", "colour", "--executor", "single"], "single"),
    ],
)
def test_the_executor_comes_from_the_non_ros_arguments(argv, expected):
    assert DEFAULT_EXECUTOR == "events"
    assert executor_argument(argv) == expected


@pytest.mark.ros
def test_an_unknown_executor_is_named_with_the_choices():
    result = subprocess.run(
        [str(executable("tracker_ptz_sim", "video_source")), "--executor", "fastest"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2
    assert "invalid choice: 'fastest'" in result.stderr
    assert "single" in result.stderr and "events" in result.stderr
