"""Street scenes: people walking over a background, with exact visible-box ground truth."""

from __future__ import annotations

import dataclasses
import itertools
import math

import cv2
import numpy as np
import pytest
from scene_files import assert_reloads_exactly

from tracker_ptz_sim.evaluation.metrics import load_mot
from tracker_ptz_sim.simulation.scene_cli import main as make_scene
from tracker_ptz_sim.simulation.scene_files import load_scene, write_scene
from tracker_ptz_sim.simulation.street import (
    STREET_PRESETS,
    StreetConfig,
    StreetScene,
    generate_street,
    median_background,
)

CLEAN = dict(noise_sigma=0.0, jpeg_quality=0, optical_blur=0.0, illumination_drift=0.0)


def small(**overrides) -> StreetConfig:
    """A small scene: 320x240, 40 frames, people 30 px tall far away and 90 px near."""
    values = dict(
        width=320,
        height=240,
        num_frames=40,
        person_height_far=30.0,
        person_height_near=90.0,
        seed=3,
    )
    return StreetConfig(**(values | overrides))


@pytest.fixture(scope="module")
def busy() -> StreetScene:
    """Walkers, a group, a crossing, every distractor and a shaking camera."""
    return generate_street(small(walkers=2, groups=1, crossings=1, camera_jitter=2))


@pytest.fixture(scope="module")
def walkers() -> StreetScene:
    return generate_street(small(walkers=3, num_frames=60, seed=5))


def boxes_of(scene: StreetScene, object_id: int) -> dict:
    return {b.frame: b for frame in scene.boxes for b in frame if b.object_id == object_id}


def consecutive():
    """A groupby key that is the same for consecutive integers."""
    count = itertools.count()
    return lambda n: n - next(count)


def inside(box, scene: StreetScene, margin: int = 1) -> bool:
    """Whether the box keeps off the frame border."""
    height, width = scene.frames.shape[1:3]
    return (
        box.x >= margin
        and box.y >= margin
        and box.x + box.width <= width - margin
        and box.y + box.height <= height - margin
    )


def test_same_config_same_scene_other_seed_other_scene():
    config = small(walkers=2, crossings=1, num_frames=12)
    a, b = generate_street(config), generate_street(config)
    assert np.array_equal(a.frames, b.frames) and np.array_equal(a.labels, b.labels)
    assert a.boxes == b.boxes
    c = generate_street(dataclasses.replace(config, seed=4))
    assert not np.array_equal(a.frames, c.frames)


def test_every_box_is_the_tight_box_of_its_visible_pixels(busy):
    assert busy.labels.dtype == np.uint16
    assert np.abs(busy.jitter).max() == 2
    rows = 0
    for n, frame_boxes in enumerate(busy.boxes):
        ids = {b.object_id for b in frame_boxes}
        assert ids == set(np.unique(busy.labels[n]).tolist()) - {0}
        for box in frame_boxes:
            ys, xs = np.nonzero(busy.labels[n] == box.object_id)
            assert (box.x, box.y) == (xs.min(), ys.min())
            assert (box.width, box.height) == (xs.max() - xs.min() + 1, ys.max() - ys.min() + 1)
            assert 0 < box.visibility <= 1
            rows += 1
    assert rows > 100


def test_visibility_is_the_share_of_the_silhouette_in_view():
    """Alone in an empty scene a person is fully visible unless the frame border cuts it."""
    no_distractors = dict(flutter=0, foliage=0, flicker=0)
    scene = generate_street(
        small(walkers=1, speed_range=(2.0, 2.5), num_frames=80, **no_distractors)
    )
    (box_by_frame,) = [boxes_of(scene, p.object_id) for p in scene.people]
    at_border = [b for b in box_by_frame.values() if not inside(b, scene, 1)]
    whole = [b for b in box_by_frame.values() if inside(b, scene, 1)]
    assert whole and all(b.visibility == 1.0 for b in whole)
    assert any(b.visibility < 0.5 for b in at_border), "it enters or leaves through a border"
    assert all(b.visibility < 1.0 for b in at_border[1:-1])


def test_people_grow_as_they_come_nearer(busy):
    """Perspective: the box height is linear in the foot row, 30 px at the horizon row 60, 90 px
    at the bottom (for a 1.7 m person; statures vary a little)."""
    checked = 0
    for person in busy.people:
        full = [b for b in boxes_of(busy, person.object_id).values() if b.visibility == 1.0]
        bottoms = np.array([b.y + b.height for b in full])
        heights = np.array([b.height for b in full])
        if len(full) < 8 or np.ptp(bottoms) < 20:
            continue
        slope, _ = np.polyfit(bottoms, heights, 1)
        assert np.corrcoef(bottoms, heights)[0, 1] > 0.8
        assert 0.2 < slope < 0.45, slope  # (90 - 30) / (240 - 60) for 1.7 m
        checked += 1
    assert checked >= 2


def test_walking_changes_the_silhouette_from_frame_to_frame(walkers):
    changes, widths = [], []
    for person in walkers.people:
        box_by_frame = boxes_of(walkers, person.object_id)
        for n in sorted(box_by_frame):
            a, b = box_by_frame[n], box_by_frame.get(n + 1)
            if b is None or a.visibility < 1 or b.visibility < 1:
                continue
            changes.append(1 - aligned_iou(walkers, a, b))
            widths.append(a.width / a.height)
    assert len(changes) > 30
    assert np.median(changes) > 0.1, "legs and arms swing"
    assert np.std(widths) / np.mean(widths) > 0.08, "the stride opens and closes"


def aligned_iou(scene: StreetScene, a, b) -> float:
    """IoU of two frames' masks of one person, aligned at the bottom centre of their boxes."""
    masks = []
    for box in (a, b):
        cx, bottom = round(box.x + box.width / 2), round(box.y + box.height)
        mask = np.zeros((200, 200), bool)
        ys, xs = np.nonzero(scene.labels[box.frame] == box.object_id)
        mask[ys - bottom + 150, xs - cx + 100] = True
        masks.append(mask)
    return float((masks[0] & masks[1]).sum() / (masks[0] | masks[1]).sum())


def test_separate_walkers_never_overlap(walkers):
    assert {p.kind for p in walkers.people} == {"walker"}
    assert max(len(b) for b in walkers.boxes) >= 2, "several in view at once"
    for frame_boxes in walkers.boxes:
        for a, b in itertools.combinations(frame_boxes, 2):
            apart_x = a.x + a.width <= b.x or b.x + b.width <= a.x
            apart_y = a.y + a.height <= b.y or b.y + b.height <= a.y
            assert apart_x or apart_y


def test_groups_walk_together(busy):
    members = [p for p in busy.people if p.kind == "group"]
    assert len(members) in (2, 3)
    assert len({p.speed for p in members}) == 1
    for a, b in itertools.combinations(members, 2):
        both = ~np.isnan(a.ground[:, 0]) & ~np.isnan(b.ground[:, 0])
        assert both.sum() > 20
        gap = np.hypot(*(a.ground[both] - b.ground[both]).T)
        assert gap.std() < 0.05 and 0.4 < gap.mean() < 2.0  # metres, side by side
        boxes_a, boxes_b = boxes_of(busy, a.object_id), boxes_of(busy, b.object_id)
        shared = set(boxes_a) & set(boxes_b)
        assert shared
        for n in shared:  # seen next to each other
            assert abs(boxes_a[n].x - boxes_b[n].x) < 3 * max(boxes_a[n].height, 30)


def test_a_stopper_stands_still_for_the_stop_duration_in_view():
    scene = generate_street(small(walkers=0, stoppers=1, num_frames=80, stop_duration=2.0, **CLEAN))
    [person] = scene.people
    assert person.kind == "stopper"
    steps = np.hypot(*np.diff(person.foot, axis=0).T)
    still = np.flatnonzero(steps == 0.0)
    assert len(still) == 2.0 * 10 - 1 and np.all(np.diff(still) == 1)  # one 2 s stand, 10 fps
    moving = steps[np.isfinite(steps) & (steps > 0)]
    assert moving.min() > 0.2  # walking before and after
    boxes = boxes_of(scene, person.object_id)
    standing = [boxes[n] for n in range(still[0], still[-1] + 2) if n in boxes]
    assert len(standing) == len(still) + 1  # seen while standing
    assert len({(b.x, b.y, b.width, b.height) for b in standing}) == 1  # the very same box


def test_crossing_pairs_hide_one_another(busy):
    pair = [p for p in busy.people if p.kind == "crossing"]
    assert len(pair) == 2
    first, second = (boxes_of(busy, p.object_id) for p in pair)
    shared = sorted(set(first) & set(second))
    occluded = []
    for n in shared:
        a, b = first[n], second[n]
        overlap = a.x < b.x + b.width and b.x < a.x + a.width
        if overlap and inside(a, busy) and inside(b, busy):
            farther = a if a.y + a.height < b.y + b.height else b
            occluded.append(farther.visibility)
    assert occluded and min(occluded) < 0.7, "the nearer one hides the farther one"


@pytest.mark.parametrize("seed", [3, 4])
def test_a_board_hides_its_walker_completely_for_the_occlusion_time(seed):
    config = small(walkers=1, occluders=1, occlusion=1.5, num_frames=80, seed=seed, **CLEAN)
    scene = generate_street(config)
    [person] = scene.people
    boxes = boxes_of(scene, person.object_id)
    first, last = min(boxes), max(boxes)
    hidden = [n for n in range(first, last) if n not in boxes]  # not one pixel in sight
    runs = [list(run) for _, run in itertools.groupby(hidden, consecutive())]
    longest = max(runs, key=len)
    assert 15 <= len(longest) <= 15 + 4  # 1.5 s at 10 fps, a little longer walking away
    unhidden = boxes_of(generate_street(dataclasses.replace(config, occluders=0)), 1)
    assert min(unhidden[n].visibility for n in longest) > 0.5  # the board, nothing else


@pytest.mark.parametrize("kind", ["flutter", "foliage", "flicker"])
def test_distractors_move_but_are_background(kind):
    counts = dict(flutter=0, foliage=0, flicker=0) | {kind: 1}
    scene = generate_street(small(walkers=0, num_frames=40, **counts, **CLEAN))
    assert not scene.labels.any() and not any(scene.boxes)
    changed = (np.abs(np.diff(scene.frames.astype(int), axis=0)).max(axis=3) > 30).any(axis=(1, 2))
    if kind == "flicker":  # switches at random frames
        assert changed.sum() >= 2
    else:  # moves all the time
        assert changed.mean() > 0.9
    still = generate_street(
        small(walkers=0, num_frames=5, flutter=0, foliage=0, flicker=0, **CLEAN)
    )
    assert (still.frames == still.frames[0]).all(), "nothing else moves"


def test_noise_and_jpeg_change_the_pixels_not_the_truth():
    clean = generate_street(small(walkers=1, num_frames=6, **CLEAN))
    noisy = generate_street(small(walkers=1, num_frames=6, **(CLEAN | dict(noise_sigma=3.0))))
    jpeg = generate_street(small(walkers=1, num_frames=6, **(CLEAN | dict(jpeg_quality=75))))
    for other in (noisy, jpeg):
        assert np.array_equal(other.labels, clean.labels) and other.boxes == clean.boxes
    noise = noisy.frames.astype(float) - clean.frames
    assert 2.5 < noise.std() < 3.5
    error = np.abs(jpeg.frames.astype(float) - clean.frames)
    assert 0.3 < error.mean() < 6.0


def test_barely_visible_people_are_ignored(busy, tmp_path):
    rows = [b for frame in busy.boxes for b in frame]
    assert {b.conf for b in rows if b.visibility < 0.25} == {0}
    assert {b.conf for b in rows if b.visibility >= 0.25} == {1}
    ignored = sum(b.conf == 0 for b in rows)
    assert ignored > 0
    paths = write_scene(busy, tmp_path / "busy")
    conf_column = [line.split(",")[6] for line in paths.gt.read_text().splitlines()]
    assert conf_column.count("0") == ignored
    truth = load_mot(paths.gt)
    assert sum(len(v) for v in truth.values()) == len(rows) - ignored


def test_written_street_scene_reloads_exactly(tmp_path):
    scene = generate_street(small(walkers=2, crossings=1, num_frames=10))
    assert_reloads_exactly(scene, tmp_path / "street", "street")


def test_median_background_removes_what_moves(tmp_path):
    rng = np.random.default_rng(0)
    still = rng.integers(0, 256, size=(48, 64, 3), dtype=np.uint8)
    path = tmp_path / "clip.avi"
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"FFV1"), 10, (64, 48))
    for k in range(15):
        frame = still.copy()
        frame[10:30, 4 * k : 4 * k + 12] = (0, 255, 0)  # a block passing through
        writer.write(frame)
    writer.release()
    assert np.array_equal(median_background(path), still)
    assert np.array_equal(median_background(path, max_frames=5), still)


def test_a_given_background_is_used(tmp_path):
    image = np.zeros((60, 80, 3), np.uint8)
    image[:] = (20, 160, 60)
    scene = generate_street(small(walkers=1, num_frames=3, **CLEAN), background=image)
    background = scene.frames[0][scene.labels[0] == 0]
    assert np.median(background, axis=0) == pytest.approx([20, 160, 60], abs=3)


def test_make_scene_writes_a_street_preset(tmp_path):
    out = tmp_path / "walkers"
    assert make_scene([str(out), "--street", "walkers", "--num-frames", "3", "--seed", "5"]) == 0
    scene = load_scene(out)
    assert scene.config == dataclasses.replace(STREET_PRESETS["walkers"], num_frames=3, seed=5)
    assert scene.frames.shape == (3, 576, 768, 3)
    image = tmp_path / "plain.png"
    cv2.imwrite(str(image), np.full((100, 120, 3), 200, np.uint8))
    args = [str(tmp_path / "b"), "--street", "groups", "--num-frames", "2", "--background"]
    assert make_scene([*args, str(image)]) == 0
    assert load_scene(tmp_path / "b").num_frames == 2


def test_make_scene_rejects_options_that_do_not_apply(tmp_path, capsys):
    assert make_scene([str(tmp_path / "a"), "--street", "walkers", "--width", "100"]) == 2
    assert "--width" in capsys.readouterr().err
    assert make_scene([str(tmp_path / "b"), "--background", "x.png"]) == 2
    assert make_scene([str(tmp_path / "c"), "--num-frames", "2"]) == 0  # the old scenes
    assert load_scene(tmp_path / "c").config.num_objects == 2


def test_bad_configs_are_rejected_with_the_reason():
    with pytest.raises(ValueError, match="num_frames"):
        StreetConfig(num_frames=0)
    with pytest.raises(ValueError, match="speed_range"):
        StreetConfig(speed_range=(2.0, 1.0))
    with pytest.raises(ValueError, match="camera must be above head height"):
        StreetConfig(person_height_far=20, person_height_near=500)
    with pytest.raises(ValueError, match="jpeg_quality"):
        StreetConfig(jpeg_quality=101)
    with pytest.raises(ValueError, match="occluders"):
        StreetConfig(occluders=-1)
    with pytest.raises(ValueError, match="occlusion"):
        StreetConfig(occlusion=math.nan)
