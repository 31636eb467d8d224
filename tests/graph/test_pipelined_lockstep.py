"""`run_demo --frames-in-flight 3`: the lockstep replay keeps three frames in the graph at once and
the simulated camera applies each command three frames after the image it answers. The run is
as deterministic as one in series: it matches the in-process pipeline with the same delay, frame
for frame."""

from __future__ import annotations

import pytest
from demo_runs import ONE_WALKER, SWEEP_RATE, VIEW_FRACTION, run_demo

pytestmark = [pytest.mark.ros, pytest.mark.slow]

IN_FLIGHT = 3


def test_a_pipelined_replay_matches_the_in_process_graph_with_the_same_delay(tmp_path):
    from tracker_ptz_sim.bringup import pipeline
    from tracker_ptz_sim.bringup.graph import load_graph
    from tracker_ptz_sim.evaluation import metrics, run_report, scoring
    from tracker_ptz_sim.evaluation.scoring import windows_and_targets
    from tracker_ptz_sim.simulation.scene_files import write_scene
    from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

    config = dict(ONE_WALKER, seed=5)  # a walker the first sweep finds with every delay
    scene = generate_scene(SceneConfig(**config))
    paths = write_scene(scene, tmp_path / "scene")
    stdout = run_demo(paths.video, tmp_path / "run", flags=("--frames-in-flight", str(IN_FLIGHT)))
    assert "0 lockstep timeouts" in stdout
    frames = run_report.collect(tmp_path / "run" / "bag")
    graph = scoring.trace_from_frames(frames)

    def in_process(delay):
        overrides = {
            "ptz_camera": {"view_height_fraction": VIEW_FRACTION, "command_delay_frames": delay},
            "ptz_controller": {"sweep_rate": SWEEP_RATE, "mode": "servo"},
        }
        settings = pipeline.PipelineSettings.from_graph(load_graph("motion"), overrides)
        steps = pipeline.run(scene.frames, scene.stamps_ns(), settings)
        return scoring.trace_from_steps(steps, scene.fps)

    fast = in_process(IN_FLIGHT)
    assert len(graph.windows) == config["num_frames"]
    assert fast.windows == graph.windows
    assert fast.target_ids == graph.target_ids and len(fast.target_ids) >= 100
    assert fast.hypotheses == graph.hypotheses
    assert in_process(1).windows != graph.windows, "the delay changes where the camera looks"
    # Three frames (0.3 s) of delay still keep the walker in view.
    windows, targets = windows_and_targets(frames)
    follow = metrics.follow_scores(metrics.load_mot(paths.gt), windows, targets)
    assert follow.inside_share >= 0.95, follow
