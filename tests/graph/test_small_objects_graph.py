"""The small-objects graph (seed 004) as separate processes, in lockstep, on a short small-object
scene: a fixed camera showing the whole scene, MOG2 and the GM-PHD tracker find the many small
movers, scored against ground truth on box centres (`evaluation.centre_scores`)."""

from __future__ import annotations

import pytest
from demo_runs import run_demo

pytestmark = [pytest.mark.ros, pytest.mark.slow]

# Measured on this scene (60 frames, 40 movers, 24-32 in view) with config/small_objects.yaml at
# commit 169f58a: centre MOTA 0.653, IDF1 0.747, false alarms 0.015, OSPA(c = 10 px) 5.90 px. MOG2
# learns the movers of the first frames into its background, so a short clip scores lower than
# the benchmark's 200-frame scenes.
MIN_MOTA = 0.55
MIN_IDF1 = 0.6
MAX_FALSE_ALARMS = 0.05
MAX_OSPA_10 = 6.8  # px


@pytest.fixture(scope="module")
def small_scene(tmp_path_factory):
    from tracker_ptz_sim.simulation.scene_files import write_scene
    from tracker_ptz_sim.simulation.small_objects import SmallObjectsConfig, generate_small_objects

    root = tmp_path_factory.mktemp("small_objects")
    scene = generate_small_objects(SmallObjectsConfig(num_frames=60, seed=11))
    return scene, write_scene(scene, root / "scene"), root


@pytest.fixture(scope="module")
def graph_run(small_scene):
    from tracker_ptz_sim.evaluation import run_report

    _, paths, root = small_scene
    out = root / "run"
    run_demo(paths.video, out, mode="hold", graph="small_objects", small_view=False, render=True)
    return out, run_report.collect(out / "bag")


def test_the_camera_shows_the_whole_scene_and_never_moves(small_scene, graph_run):
    from tracker_msgs.msg import PtzCommand
    from tracker_msgs_py.codec import msg_to_rect
    from tracker_msgs_py.geometry import Rect

    scene, _, _ = small_scene
    out, frames = graph_run
    height, width = scene.frames.shape[1:3]
    assert len(frames) == scene.num_frames
    records = list(frames.values())
    assert {msg_to_rect(r.state.window) for r in records} == {Rect(0, 0, width, height)}
    assert {(r.state.pan, r.state.tilt, r.state.zoom) for r in records} == {(0.0, 0.0, 1.0)}
    assert {r.command.mode for r in records} == {PtzCommand.MODE_HOLD}
    assert (out / "annotated.mp4").stat().st_size > 0 and (out / "summary.json").exists()


def test_the_tracks_sit_on_the_small_movers(small_scene, graph_run):
    from tracker_ptz_sim.evaluation import scoring

    _, paths, _ = small_scene
    _, frames = graph_run
    scores = scoring.score_trace(scoring.trace_from_frames(frames), paths.gt, centres=True)
    centres = scores["centres"]
    assert centres["mota"] >= MIN_MOTA, centres
    assert centres["idf1"] >= MIN_IDF1, centres
    assert centres["false_alarm_rate"] <= MAX_FALSE_ALARMS, centres
    assert centres["ospa_10px"] <= MAX_OSPA_10, centres
    # many movers are tracked at once, not a few
    assert centres["estimates_per_frame"] >= 0.6 * centres["truth_per_frame"] >= 0.6 * 20


def test_in_process_pipeline_matches_the_graph(small_scene, graph_run):
    """The benchmark's fast path gives the graph's windows and observed tracks on this scene."""
    from tracker_ptz_sim.bringup import pipeline
    from tracker_ptz_sim.bringup.graph import load_graph
    from tracker_ptz_sim.evaluation import scoring

    scene, _, _ = small_scene
    _, frames = graph_run
    graph = scoring.trace_from_frames(frames)
    settings = pipeline.PipelineSettings.from_graph(load_graph("small_objects"))
    assert settings.motion.detector_method == "mog2"
    assert settings.motion.tracker_method == "gm_phd"
    fast = scoring.trace_from_steps(
        pipeline.run(scene.frames, scene.stamps_ns(), settings), scene.fps
    )
    assert fast.windows == graph.windows
    assert fast.hypotheses == graph.hypotheses
