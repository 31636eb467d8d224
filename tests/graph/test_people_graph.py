"""The shipped surveillance graph on real people: the first 12 s of vtest.avi through the node
graph (person_motion detector, byte tracker, people only followed), against the in-process
pipeline the benchmark scores."""

from __future__ import annotations

import itertools

import cv2
import pytest
from demo_runs import run_demo

pytestmark = [pytest.mark.ros, pytest.mark.slow]

FRAMES = 120


@pytest.fixture(scope="module")
def people_run(vtest_clip, tmp_path_factory):
    from tracker_ptz_sim.evaluation import run_report
    from tracker_ptz_sim.simulation.frame_sources import video_frames

    root = tmp_path_factory.mktemp("people")
    video = root / "vtest_first.avi"
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (768, 576))
    for frame in itertools.islice(video_frames(vtest_clip), FRAMES):
        writer.write(frame)
    writer.release()
    out = root / "run"
    run_demo(video, out, small_view=False, graph="surveillance")
    return video, out, run_report.collect(out / "bag")


def test_the_camera_follows_a_person_and_says_so(people_run):
    _, out, frames = people_run
    targets = [r.target for r in frames.values() if r.target is not None]
    locked = [t for t in targets if t.locked]
    assert len(targets) == FRAMES and len(locked) >= FRAMES // 2
    assert {t.track.label for t in locked} == {"person"}
    rows = [line.split(",") for line in (out / "tracks.txt").read_text().splitlines()]
    assert rows and {row[7] for row in rows} <= {"1", "-1"} and "1" in {row[7] for row in rows}
    labels = {b.label for r in frames.values() if r.detections for b in r.detections.blobs}
    assert "person" in labels


def test_the_in_process_pipeline_tracks_people_as_the_graph_does(people_run):
    from tracker_ptz_sim.bringup import pipeline
    from tracker_ptz_sim.bringup.graph import load_graph
    from tracker_ptz_sim.evaluation import scoring
    from tracker_ptz_sim.simulation.frame_sources import open_source

    video, _, frames = people_run
    settings = pipeline.PipelineSettings.from_graph(load_graph("surveillance"))
    images, stamps = itertools.tee(open_source(video).frames())
    steps = pipeline.run((f.image for f in images), (f.stamp_ns for f in stamps), settings)
    fast = scoring.trace_from_steps(steps, 10.0, settings.followed_labels)
    graph = scoring.trace_from_frames(frames, settings.followed_labels)
    assert fast.windows == graph.windows
    assert fast.target_ids == graph.target_ids and len(fast.target_ids) >= FRAMES // 2
    assert fast.hypotheses == graph.hypotheses
