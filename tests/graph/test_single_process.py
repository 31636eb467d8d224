"""`run_demo --single-process`: every node in one process on one executor (graph_host) gives the
same tracks, windows and targets as the separate processes, frame for frame."""

from __future__ import annotations

import json

import pytest
from demo_runs import run_demo

pytestmark = [pytest.mark.ros, pytest.mark.slow]


def test_one_process_tracks_exactly_as_separate_processes(tmp_path):
    from tracker_ptz_sim.evaluation import run_report, scoring
    from tracker_ptz_sim.simulation.scene_files import write_scene
    from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

    config = SceneConfig(
        width=640,
        height=480,
        num_frames=100,
        num_objects=2,
        object_size_range=(30, 60),
        speed_range=(25.0, 40.0),
        seed=9,
    )
    paths = write_scene(generate_scene(config), tmp_path / "scene")
    traces = {}
    for name, flags in {"processes": (), "one_process": ("--single-process",)}.items():
        out = tmp_path / name
        stdout = run_demo(paths.video, out, flags=flags)
        assert "0 lockstep timeouts" in stdout
        traces[name] = scoring.trace_from_frames(run_report.collect(out / "bag"))
        traces[name + "_mot"] = (out / "tracks.txt").read_text()
        # the camera's latency covers every frame: in one process its last report is the one
        # each node publishes as it is torn down with the stream's end
        latency = json.loads((out / "summary.json").read_text())["run"]["camera_latency_ms"]
        assert latency["count"] == 100, name
    assert (tmp_path / "one_process/logs/graph_host.log").exists()
    separate, single = traces["processes"], traces["one_process"]
    assert len(single.windows) == 100 and single.target_ids
    assert single.windows == separate.windows and single.target_ids == separate.target_ids
    assert single.hypotheses == separate.hypotheses
    assert traces["one_process_mot"] == traces["processes_mot"] != ""
