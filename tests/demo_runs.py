"""run_demo as the graph tests run it: the whole graph as separate processes on a video."""

from __future__ import annotations

import json
import subprocess

from ros_process import executable

# One person-sized object walking with two turns, never closer than 80 px to a border (SceneConfig).
ONE_WALKER = dict(
    width=640,
    height=480,
    num_frames=150,
    num_objects=1,
    object_size_range=(30, 60),
    speed_range=(25.0, 40.0),
    turns=2,
    seed=9,
)
VIEW_FRACTION = 0.35  # a 168 px view on a 640x480 scene
SWEEP_RATE = 0.6  # rad/s: 170 px/s, the search crosses the scene in about 3 s


def motion_only_settings() -> list[str]:
    """node.param=value settings that make a graph built on surveillance.yaml motion-only, as
    config/motion.yaml makes the surveillance graph (for graphs without a motion variant)."""
    from tracker_ptz_sim.bringup.graph import load_graph, node_parameters

    motion = [p for p in load_graph("motion").params_files if p.name == "motion.yaml"]
    return [
        f"{node}.{name}={json.dumps(value)}"
        for node in ("ssim_detector", "tracker")
        for name, value in node_parameters(motion, node).items()
    ]


def run_demo(
    video,
    out,
    *settings,
    mode="servo",
    render=False,
    small_view=True,
    graph="motion",
    flags=(),
):
    """run_demo on `video` with `graph`; `settings` are node.param=value; `small_view`: the
    tests' 168 px view and fast sweep (else the graph's own settings)."""
    command = [
        str(executable("tracker_ptz_sim", "run_demo")),
        "--video",
        str(video),
        "--out",
        str(out),
    ]
    command += ["--mode", mode, "--graph", graph]
    if small_view:
        command += ["--set", f"ptz_camera.view_height_fraction={VIEW_FRACTION}"]
        command += ["--set", f"ptz_controller.sweep_rate={SWEEP_RATE}"]
    for setting in settings:
        command += ["--set", setting]
    if not render:
        command.append("--no-video")
    command += list(flags)
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    return result.stdout


def with_logs(result, out, lines=40):
    """The run's problems and the last log lines of every node they name: what a failed
    assertion shows (the test's directory is gone after a CI run)."""
    report = list(result.problems)
    for log in sorted((out / "logs").glob("*.log")):
        if any(log.stem in problem for problem in result.problems):
            tail = log.read_text(errors="replace").splitlines()[-lines:]
            report.append(f"--- {log.name}:\n" + "\n".join(tail))
    return "\n".join(report)
