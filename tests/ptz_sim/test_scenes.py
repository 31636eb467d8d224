"""Synthetic scenes: deterministic, ground truth consistent with the pixels, lossless files."""

from __future__ import annotations

import numpy as np
import pytest

from tracker_ptz_sim.evaluation.metrics import load_mot
from tracker_ptz_sim.simulation.scene_files import load_scene, scene_video, write_scene
from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene


def test_same_config_same_scene_other_seed_other_scene():
    config = SceneConfig(num_frames=12, num_objects=3, seed=5)
    a, b = generate_scene(config), generate_scene(config)
    assert np.array_equal(a.frames, b.frames) and np.array_equal(a.labels, b.labels)
    c = generate_scene(SceneConfig(num_frames=12, num_objects=3, seed=6))
    assert not np.array_equal(a.frames, c.frames)


def test_labels_lie_inside_their_boxes_and_visibility_matches():
    scene = generate_scene(
        SceneConfig(
            num_frames=30, num_objects=3, num_occluders=4, occluder_size_range=(60, 100), seed=2
        )
    )
    occluded = 0
    for n, boxes in enumerate(scene.boxes):
        for box in boxes:
            ys, xs = np.nonzero(scene.labels[n] == box.object_id)
            if box.visibility > 0:
                assert xs.min() >= np.floor(box.x) and xs.max() < np.ceil(box.x + box.width)
                assert ys.min() >= np.floor(box.y) and ys.max() < np.ceil(box.y + box.height)
            full = max(1.0, min(box.width, 320) * min(box.height, 240))
            assert len(xs) <= full + 1e-9
            occluded += box.visibility < 1.0
    assert occluded > 0, "occluders hide parts of the objects"


def test_objects_move_and_entries_exits_leave_empty_frames():
    scene = generate_scene(
        SceneConfig(
            num_frames=120, num_objects=1, entries_exits=True, speed_range=(60.0, 80.0), seed=1
        )
    )
    counts = [len(b) for b in scene.boxes]
    assert 0 in counts and 1 in counts
    present = [b[0] for b in scene.boxes if b]
    assert abs(present[-1].x - present[0].x) + abs(present[-1].y - present[0].y) > 50


def test_camera_jitter_shifts_the_whole_image():
    still = generate_scene(SceneConfig(num_frames=6, noise_sigma=0.0, seed=4))
    shaky = generate_scene(SceneConfig(num_frames=6, noise_sigma=0.0, camera_jitter=3, seed=4))
    assert np.abs(shaky.jitter).max() <= 3 and np.abs(shaky.jitter).max() > 0
    assert not np.array_equal(still.frames, shaky.frames)


def test_written_scene_reloads_bit_exact_with_mot_ground_truth(tmp_path):
    scene = generate_scene(SceneConfig(num_frames=8, num_objects=2, seed=3))
    paths = write_scene(scene, tmp_path / "s")
    loaded = load_scene(paths.root)
    assert np.array_equal(loaded.frames, scene.frames) and np.array_equal(
        loaded.labels, scene.labels
    )
    assert scene_video(paths.root) == paths.video
    truth = load_mot(paths.gt)
    first = scene.boxes[0][0]
    assert truth[1][first.object_id].x == pytest.approx(first.x)
    assert sum(len(v) for v in truth.values()) == sum(len(b) for b in scene.boxes)


def test_bad_configs_are_rejected_with_the_reason():
    with pytest.raises(ValueError, match="num_frames"):
        SceneConfig(num_frames=0)
    with pytest.raises(ValueError, match="speed_range"):
        SceneConfig(speed_range=(5.0, 1.0))
