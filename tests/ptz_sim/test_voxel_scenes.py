"""Voxel scenes (seed 002): deterministic occupancy volumes, exact centroids, scripted contacts and
crossings, holes, salt noise and static spurious blobs."""

from __future__ import annotations

import dataclasses
import itertools
import time

import numpy as np
import pytest

from tracker_ptz_sim.simulation.voxel_scenes import (
    ROOM_SIZE_M,
    VoxelFrame,
    VoxelSceneConfig,
    contact_intervals,
    dense_grid,
    grid_shape,
    scene_events,
    spurious_blobs,
    truth_tracks,
    voxel_scene,
)

CLEAN = dict(hole_rate=0.0, salt_rate=0.0, spurious=0)


def frames_of(config: VoxelSceneConfig, count: int) -> list[VoxelFrame]:
    return list(itertools.islice(voxel_scene(config), count))


def linear(voxels: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray:
    return np.ravel_multi_index(tuple(voxels.T), shape)


def velocities(config: VoxelSceneConfig) -> np.ndarray:
    return np.gradient(truth_tracks(config)[:, :, :2], axis=0) * config.fps


def test_grid_shape_at_2_3_4_cm():
    assert grid_shape(0.02) == (200, 250, 105)
    assert grid_shape(0.03) == (133, 167, 70)
    assert grid_shape(0.04) == (100, 125, 52)


def test_same_seed_same_frames_other_seed_other_frames():
    config = VoxelSceneConfig(frames=20, seed=3)
    a, b = frames_of(config, 3), frames_of(config, 3)
    for fa, fb in zip(a, b, strict=True):
        assert np.array_equal(fa.voxels, fb.voxels)
        assert np.array_equal(fa.truth_centroids, fb.truth_centroids)
    c = frames_of(dataclasses.replace(config, seed=4), 1)[0]
    assert not np.array_equal(a[0].truth_centroids, c.truth_centroids)


def test_people_move_the_same_whatever_the_voxel_size_noise_and_blobs():
    base = VoxelSceneConfig(people=3, frames=80, seed=2)
    other = dataclasses.replace(base, voxel_size=0.04, hole_rate=0.2, salt_rate=0.0, spurious=5)
    assert np.array_equal(truth_tracks(base), truth_tracks(other))
    assert scene_events(base) == scene_events(other)


@pytest.mark.parametrize("voxel_size", [0.02, 0.03, 0.04])
def test_voxels_are_unique_int32_indices_inside_the_grid(voxel_size):
    config = VoxelSceneConfig(people=6, frames=4, voxel_size=voxel_size, salt_rate=5e-3, spurious=4)
    shape = grid_shape(voxel_size)
    for frame in voxel_scene(config):
        v = frame.voxels
        assert v.dtype == np.int32 and v.ndim == 2 and v.shape[1] == 3
        assert v.min() >= 0 and np.all(v.max(axis=0) < shape)
        assert len(np.unique(linear(v, shape))) == len(v)
        assert dense_grid(frame, shape).sum() == len(v)
        assert frame.time == pytest.approx(frame.index / config.fps)
        assert np.array_equal(frame.truth_ids, np.arange(1, 7))


@pytest.mark.parametrize("people", [2, 4, 6])
def test_people_stay_inside_the_room(people):
    for seed in range(2):
        truth = truth_tracks(VoxelSceneConfig(people=people, seed=seed))
        assert truth.shape == (250, people, 3)
        assert np.all(truth[..., :2] >= 0.3 - 1e-9)
        assert np.all(truth[..., :2] <= np.array(ROOM_SIZE_M[:2]) - 0.3 + 1e-9)
        assert np.all((truth[..., 2] > 0.6) & (truth[..., 2] < 1.0))  # centre of mass of a body


def test_walking_speeds_are_human():
    config = VoxelSceneConfig(people=6, seed=1)
    speed = np.linalg.norm(velocities(config), axis=2)
    assert 0.3 <= np.median(speed) <= 1.2
    assert speed.max() < 2.0


def test_raster_centroid_of_each_person_matches_the_truth_at_2_cm():
    config = VoxelSceneConfig(people=4, frames=60, seed=5, **CLEAN)
    checked = 0
    for frame in itertools.islice(voxel_scene(config), 0, None, 6):
        truth = frame.truth_centroids
        apart = all(
            np.linalg.norm(truth[a, :2] - truth[b, :2]) > 0.6
            for a, b in itertools.combinations(range(len(truth)), 2)
        )
        if not apart:
            continue
        centres = (frame.voxels + 0.5) * config.voxel_size
        owner = np.argmin(np.linalg.norm(centres[:, None, :2] - truth[None, :, :2], axis=2), axis=1)
        for person, centroid in enumerate(truth):
            mine = centres[owner == person]
            assert len(mine) > 3000
            assert np.linalg.norm(mine.mean(axis=0) - centroid) < 0.03
        checked += 1
    assert checked >= 3


def test_a_long_contact_and_a_crossing_with_4_people_seed_0():
    config = VoxelSceneConfig(people=4, seed=0)
    assert any(last - first + 1 >= 25 for _, _, first, last in contact_intervals(config))
    assert crossings(config)


def crossings(config: VoxelSceneConfig) -> list[tuple[int, int, int]]:
    """(a, b, frame) of each pair's closest approach closer than 0.5 m while walking at least 60
    degrees apart."""
    truth, v = truth_tracks(config), velocities(config)
    unit = v / np.linalg.norm(v, axis=2, keepdims=True)
    found = []
    for a, b in itertools.combinations(range(config.people), 2):
        d = np.linalg.norm(truth[:, a, :2] - truth[:, b, :2], axis=1)
        apart = np.sum(unit[:, a] * unit[:, b], axis=1) <= 0.5
        d = np.where(apart, d, np.inf)
        if d.min() < 0.5:
            found.append((a + 1, b + 1, int(np.argmin(d))))
    return found


@pytest.mark.parametrize("people", [2, 3, 5, 6])
def test_every_scene_gets_a_long_contact_and_a_crossing(people):
    for seed in range(2):
        config = VoxelSceneConfig(people=people, seed=seed)
        kinds = {e.kind for e in scene_events(config)}
        assert kinds == {"contact", "crossing"}
        assert any(last - first + 1 >= 25 for _, _, first, last in contact_intervals(config))
        assert crossings(config)


def test_scripted_contacts_touch_side_by_side_and_crossings_pass_close():
    config = VoxelSceneConfig(people=4, seed=7)
    truth, v = truth_tracks(config), velocities(config)
    events = scene_events(config)
    assert events
    for e in events:
        a, b = e.a - 1, e.b - 1
        frames = np.arange(e.core[0], e.core[1] + 1)
        d = np.linalg.norm(truth[frames, a, :2] - truth[frames, b, :2], axis=1)
        if e.kind == "contact":
            assert len(frames) >= 25
            assert np.all((d > 0.34) & (d < 0.46))
            cosine = np.sum(v[frames, a] * v[frames, b], axis=1) / (
                np.linalg.norm(v[frames, a], axis=1) * np.linalg.norm(v[frames, b], axis=1)
            )
            assert cosine.min() > 0.95
        else:
            assert 0.24 < d[0] < 0.46
            assert any(
                (a + 1, b + 1) == (i, j) and i < j and abs(f - e.core[0]) <= 1
                for i, j, f in crossings(config)
            )


def test_no_events_without_contacts():
    assert scene_events(VoxelSceneConfig(people=4, contacts=False)) == []


def test_hole_rate_drops_that_share_of_the_people_voxels():
    clean = VoxelSceneConfig(people=2, frames=3, seed=1, **CLEAN)
    holed = dataclasses.replace(clean, hole_rate=0.1)
    full = sum(len(f.voxels) for f in voxel_scene(clean))
    kept = sum(len(f.voxels) for f in voxel_scene(holed))
    assert kept / full == pytest.approx(0.9, abs=0.01)


def test_salt_rate_switches_on_that_share_of_the_empty_cells():
    clean = VoxelSceneConfig(people=2, frames=3, seed=1, **CLEAN)
    salted = dataclasses.replace(clean, salt_rate=1e-3)
    shape = grid_shape(clean.voxel_size)
    cells = shape[0] * shape[1] * shape[2]
    extra, expected = 0, 0.0
    for a, b in zip(voxel_scene(clean), voxel_scene(salted), strict=True):
        assert np.all(np.isin(linear(a.voxels, shape), linear(b.voxels, shape)))
        extra += len(b.voxels) - len(a.voxels)
        expected += 1e-3 * (cells - len(a.voxels))
    assert abs(extra - expected) < 5 * np.sqrt(expected)


def test_spurious_blobs_are_static_and_away_from_the_walls():
    config = VoxelSceneConfig(people=3, frames=8, spurious=4, seed=2)
    shape = grid_shape(config.voxel_size)
    blobs = spurious_blobs(config)
    assert [b.kind for b in blobs] == ["chair", "jacket", "carved_chair", "box"]
    for frame in voxel_scene(config):
        occupied = linear(frame.voxels, shape)
        for blob in blobs:
            assert np.all(np.isin(linear(blob.voxels, shape), occupied))
    for blob in blobs:
        metres = (blob.voxels + 0.5) * config.voxel_size
        assert np.all(metres[:, :2] > 0.4) and np.all(
            metres[:, :2] < np.array(ROOM_SIZE_M[:2]) - 0.4
        )
    fewer = spurious_blobs(dataclasses.replace(config, spurious=2))
    assert all(
        a.centre == b.centre and np.array_equal(a.voxels, b.voxels)
        for a, b in zip(fewer, blobs[:2], strict=True)
    )


def passes_person_test(voxels: np.ndarray, voxel_size: float) -> bool:
    """The seed's blob test: voxels x voxel edge (cm) > 3000 and vertical extent >= 60 cm."""
    edge_cm = voxel_size * 100
    extent_cm = (np.ptp(voxels[:, 2]) + 1) * edge_cm
    return len(voxels) * edge_cm > 3000 and extent_cm >= 60


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_chair_passes_the_person_test_and_the_jacket_does_not(seed):
    blobs = spurious_blobs(VoxelSceneConfig(spurious=4, seed=seed))
    passed = {b.kind: passes_person_test(b.voxels, 0.02) for b in blobs}
    assert passed == {"chair": True, "jacket": False, "carved_chair": True, "box": False}
    coarse = spurious_blobs(VoxelSceneConfig(spurious=4, seed=seed, voxel_size=0.04))
    assert [passes_person_test(b.voxels, 0.04) for b in coarse] == [True, False, False, False]


def test_invalid_configs_are_rejected():
    for bad in (
        dict(people=0),
        dict(people=7),
        dict(frames=0),
        dict(voxel_size=0.0),
        dict(hole_rate=1.0),
    ):
        with pytest.raises(ValueError):
            VoxelSceneConfig(**bad)


def test_a_2_cm_frame_with_6_people_takes_well_under_50_ms():
    config = VoxelSceneConfig(people=6, frames=12)
    frames = voxel_scene(config)
    next(frames)  # the plan (trajectories) is made once per scene
    durations = []
    for _ in range(10):
        start = time.perf_counter()
        next(frames)
        durations.append(time.perf_counter() - start)
    assert min(durations) < 0.05
