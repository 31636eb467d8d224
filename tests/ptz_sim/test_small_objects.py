"""Small-object scenes: many small movers, crossings, static occluders, exact ground truth."""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np
import pytest
from scene_files import assert_reloads_exactly

from tracker_ptz_sim.evaluation.metrics import load_mot
from tracker_ptz_sim.simulation.scene_cli import main as make_scene
from tracker_ptz_sim.simulation.scene_files import load_scene
from tracker_ptz_sim.simulation.small_objects import (
    SmallObjectsConfig,
    SmallObjectsScene,
    generate_small_objects,
)

CLEAN = dict(noise_sigma=0.0, jpeg_quality=0, optical_blur=0.0, illumination_drift=0.0)


def small(**overrides) -> SmallObjectsConfig:
    """A small scene: 320x240, 60 frames, 20 movers, 3 crossings, 3 occluders."""
    values = dict(width=320, height=240, num_frames=60, num_objects=20, crossings=3, seed=4)
    return SmallObjectsConfig(**(values | overrides))


@pytest.fixture(scope="module")
def scene() -> SmallObjectsScene:
    return generate_small_objects(small())


def rows(scene: SmallObjectsScene) -> list:
    return [b for frame in scene.boxes for b in frame]


def boxes_of(scene: SmallObjectsScene, object_id: int) -> dict:
    return {b.frame: b for frame in scene.boxes for b in frame if b.object_id == object_id}


def overlap(a, b) -> bool:
    return (
        a.x < b.x + b.width
        and b.x < a.x + a.width
        and a.y < b.y + b.height
        and b.y < a.y + a.height
    )


def test_same_config_same_scene_other_seed_other_scene():
    config = small(num_frames=8)
    a, b = generate_small_objects(config), generate_small_objects(config)
    assert np.array_equal(a.frames, b.frames) and np.array_equal(a.labels, b.labels)
    assert a.boxes == b.boxes
    c = generate_small_objects(dataclasses.replace(config, seed=5))
    assert not np.array_equal(a.frames, c.frames)


def test_many_movers_in_view_some_born_late_some_leaving():
    config = small(num_frames=120, num_objects=30, speed_range=(2.0, 3.0), **CLEAN)
    scene = generate_small_objects(config)
    in_view = [sum(b.conf for b in frame) for frame in scene.boxes]
    assert min(in_view) >= 5 and np.mean(in_view) >= 10
    first = {
        m.object_id: int(np.flatnonzero(m.present)[0]) for m in scene.movers if m.present.any()
    }
    last = {
        m.object_id: int(np.flatnonzero(m.present)[-1]) for m in scene.movers if m.present.any()
    }
    assert len(first) >= 28
    assert sum(f > 0 for f in first.values()) >= 3, "born mid-clip"
    assert sum(f < 119 for f in last.values()) >= 3, "left through a border"
    assert {m.species for m in scene.movers} == {"fly", "bee", "ant", "beetle", "bird"}


def test_fully_visible_boxes_are_10_to_30_px(scene):
    full = [b for b in rows(scene) if b.visibility == 1.0]
    assert len(full) > 200
    longer = np.array([max(b.width, b.height) for b in full])
    assert longer.min() >= 10 and longer.max() <= 30
    assert np.ptp(longer) >= 10, "sizes spread over the range"


def test_motion_is_nearly_constant_velocity(scene):
    """One-step constant-velocity prediction of the true centre is off by well under a pixel."""
    errors = []
    for mover in scene.movers:
        centre = mover.centre[mover.present]
        if len(centre) >= 3:
            errors.append(np.hypot(*(centre[2:] - 2 * centre[1:-1] + centre[:-2]).T))
    error = np.concatenate(errors)
    assert np.median(error) < 0.1 and np.quantile(error, 0.95) < 0.5
    speeds = np.concatenate(
        [np.hypot(*np.diff(m.centre[m.present], axis=0).T) for m in scene.movers]
    )
    assert speeds.min() > 0.8 * 0.9 and speeds.max() < 3.0 * 1.1


def test_forced_crossings_overlap(scene):
    assert len(scene.crossings) == 3
    pairs = set()
    for a, b, frame in scene.crossings:
        first, second = scene.movers[a - 1], scene.movers[b - 1]
        assert (first.partner, second.partner) == (b, a)
        assert np.allclose(first.centre[frame], second.centre[frame])
        boxes_a, boxes_b = boxes_of(scene, a), boxes_of(scene, b)
        assert frame in boxes_a and frame in boxes_b
        if any(overlap(boxes_a[n], boxes_b[n]) for n in set(boxes_a) & set(boxes_b)):
            pairs.add((a, b))
        farther = a if first.depth < second.depth else b
        assert boxes_of(scene, farther)[frame].visibility < 1, "the nearer one hides it"
    assert len(pairs) == 3


def test_movers_hide_behind_the_occluders(scene):
    mask = scene.occluder_mask
    assert 0.01 < mask.mean() < 0.3
    assert not scene.labels[:, mask].any(), "occluders are background"
    hidden = [b for b in rows(scene) if b.visibility == 0]
    assert hidden and {b.conf for b in hidden} == {0}
    behind = [m for m in scene.movers if m.role == "occluded"]
    assert len(behind) == 3
    for mover in behind:
        box_by_frame = boxes_of(scene, mover.object_id)
        visibility = [box_by_frame[n].visibility for n in sorted(box_by_frame)]
        assert min(visibility) == 0 and max(visibility) > 0.5  # seen, then hidden
        for box in box_by_frame.values():
            if box.visibility == 0:  # its full box, on the occluder
                x, y = int(box.x), int(box.y)
                assert mask[y : y + int(box.height), x : x + int(box.width)].any()


def test_labels_agree_with_the_visible_boxes(scene):
    assert scene.labels.dtype == np.uint16
    checked = 0
    for n, frame_boxes in enumerate(scene.boxes):
        seen = {b.object_id for b in frame_boxes if b.visibility > 0}
        assert seen == set(np.unique(scene.labels[n]).tolist()) - {0}
        for box in frame_boxes:
            assert 0 <= box.visibility <= 1
            assert box.conf == (1 if box.visibility >= 0.25 else 0)
            ys, xs = np.nonzero(scene.labels[n] == box.object_id)
            if box.visibility == 0:
                assert len(xs) == 0
                continue
            tight = (xs.min(), ys.min(), xs.max() + 1, ys.max() + 1)
            given = (box.x, box.y, box.x + box.width, box.y + box.height)
            assert np.abs(np.subtract(tight, given)).max() <= 1
            checked += 1
    assert checked > 500


def test_visibility_counts_pixels_hidden_by_nearer_movers():
    scene = generate_small_objects(small(num_occluders=0, num_frames=30, **CLEAN))
    covered = 0
    for frame_boxes in scene.boxes:
        for a, b in itertools.combinations(frame_boxes, 2):
            if overlap(a, b) and min(a.visibility, b.visibility) < 1:
                covered += 1
    assert covered > 0


def test_noise_and_jpeg_change_the_pixels_not_the_truth():
    clean = generate_small_objects(small(num_frames=4, **CLEAN))
    noisy = generate_small_objects(small(num_frames=4, **(CLEAN | dict(noise_sigma=3.0))))
    jpeg = generate_small_objects(small(num_frames=4, **(CLEAN | dict(jpeg_quality=75))))
    for other in (noisy, jpeg):
        assert np.array_equal(other.labels, clean.labels) and other.boxes == clean.boxes
    assert 2.5 < (noisy.frames.astype(float) - clean.frames).std() < 3.5
    assert 0.3 < np.abs(jpeg.frames.astype(float) - clean.frames).mean() < 6.0


def test_a_given_background_is_used():
    image = np.zeros((60, 80, 3), np.uint8)
    image[:] = (20, 160, 60)
    scene = generate_small_objects(small(num_frames=2, num_occluders=0, **CLEAN), image)
    background = scene.frames[0][scene.labels[0] == 0]
    assert np.median(background, axis=0) == pytest.approx([20, 160, 60], abs=3)


def test_written_scene_reloads_exactly(tmp_path):
    scene = generate_small_objects(small(num_frames=6))
    paths = assert_reloads_exactly(scene, tmp_path / "small", "small_objects")
    ignored = sum(b.conf == 0 for b in rows(scene))
    truth = load_mot(paths.gt)
    assert sum(len(v) for v in truth.values()) == len(rows(scene)) - ignored


def test_make_scene_writes_a_small_object_scene(tmp_path, capsys):
    out = tmp_path / "small"
    args = [str(out), "--small-objects", "--num-frames", "3", "--width", "160", "--height"]
    assert make_scene([*args, "120", "--num-objects", "6", "--crossings", "1", "--seed", "2"]) == 0
    scene = load_scene(out)
    expected = SmallObjectsConfig(
        width=160, height=120, num_frames=3, num_objects=6, crossings=1, seed=2
    )
    assert scene.config == expected and scene.frames.shape == (3, 120, 160, 3)
    assert make_scene([str(tmp_path / "a"), "--small-objects", "--turns", "2"]) == 2
    assert "--turns do not apply with --small-objects" in capsys.readouterr().err
    assert make_scene([str(tmp_path / "b"), "--crossings", "2"]) == 2
    assert "only apply with --small-objects" in capsys.readouterr().err
    assert make_scene([str(tmp_path / "c"), "--small-objects", "--num-objects", "0"]) == 2
    assert "num_objects" in capsys.readouterr().err


def test_bad_configs_are_rejected_with_the_reason():
    with pytest.raises(ValueError, match=r"num_objects must be in \[1, 200\]"):
        SmallObjectsConfig(num_objects=201)
    with pytest.raises(ValueError, match="num_objects must be in"):
        SmallObjectsConfig(num_objects=0, crossings=0)
    with pytest.raises(ValueError, match="2 \\* crossings"):
        SmallObjectsConfig(num_objects=5, crossings=3)
    with pytest.raises(ValueError, match="object_size_range"):
        SmallObjectsConfig(object_size_range=(30, 10))
    with pytest.raises(ValueError, match="max >= 1.5 \\* min"):
        SmallObjectsConfig(object_size_range=(20, 24))
    with pytest.raises(ValueError, match="speed_range"):
        SmallObjectsConfig(speed_range=(3.0, 1.0))
    with pytest.raises(ValueError, match="turn_sigma"):
        SmallObjectsConfig(turn_sigma=math.nan)
    with pytest.raises(ValueError, match="num_occluders"):
        SmallObjectsConfig(num_occluders=-1)
    with pytest.raises(ValueError, match="jpeg_quality"):
        SmallObjectsConfig(jpeg_quality=101)
    with pytest.raises(ValueError, match="late_fraction"):
        SmallObjectsConfig(late_fraction=1.5)
    with pytest.raises(ValueError, match="scene size"):
        SmallObjectsConfig(width=32)
