"""Video without people: the surveillance graph tracks what moves but never follows it."""

from __future__ import annotations

import numpy as np
import pytest

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def people_free_scene(vtest_clip):
    """20 s over vtest.avi's empty plaza (its median): fluttering tape, shimmering bushes,
    flickering lamps and two cars driving through; nobody."""
    from tracker_ptz_sim.simulation import street

    config = street.StreetConfig(
        walkers=0, flutter=2, foliage=2, flicker=2, cars=2, num_frames=200, seed=5
    )
    scene = street.generate_street(config, street.median_background(vtest_clip))
    assert not any(scene.boxes) and scene.config.cars == 2
    return scene


def run(scene, overrides=None):
    from tracker_ptz_sim.bringup import pipeline
    from tracker_ptz_sim.bringup.graph import load_graph

    settings = pipeline.PipelineSettings.from_graph(load_graph("surveillance"), overrides or {})
    return list(pipeline.run(scene.frames, scene.stamps_ns(), settings))


def test_the_camera_never_locks_on_a_flag_a_bush_a_lamp_or_a_car(people_free_scene):
    steps = run(people_free_scene)
    assert [s.target_id for s in steps if s.target_id is not None] == []
    labels = {str(label) for s in steps for label in s.tracks.labels}
    assert "motion" in labels  # what moves is tracked, labelled, and left alone
    person_tracks = {
        int(i)
        for s in steps
        for i, label, status in zip(s.tracks.ids, s.tracks.labels, s.tracks.status, strict=True)
        if label == "person" and status == 1
    }
    assert person_tracks == set()


def test_told_to_follow_any_label_it_follows_what_moves(people_free_scene):
    """The same scene with `track_labels: ['any']`: the camera follows the motion tracks (the cars),
    so it is the label, not a lack of tracks, that keeps it still above."""
    steps = run(people_free_scene, {"tracker": {"track_labels": ["any"]}})
    locked = np.mean([s.target_id is not None for s in steps])
    assert locked > 0.05, f"locked {locked:.0%}"
