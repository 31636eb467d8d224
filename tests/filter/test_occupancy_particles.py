"""Seed 002's particle filters on occupancy grids: the likelihood's worked values, scene filtering,
components, propagation, blocking, initiation and deletion, in 3-D and on 2-D masks."""

from __future__ import annotations

import numpy as np
import pytest

from tracker_filter.observation import Detections, Observation
from tracker_filter.occupancy.occupancy_grid import GridGeometry, OccupancyGrid, components
from tracker_filter.occupancy.occupancy_particles import (
    OccupancyFilterConfig,
    OccupancyParticleFilters,
    _snap_unique,
    _surface_weights,
    jitter_widths,
    surface_weight,
)
from tracker_filter.occupancy.occupancy_tracker import (
    METHOD,
    OccupancyTracker,
    OccupancyTrackerConfig,
)
from tracker_filter.tracking import TrackStatus
from tracker_msgs_py.geometry import Rect, iou_matrix

ROOM = GridGeometry((200, 250, 105), (0.02, 0.02, 0.02))  # the thesis's room at 2 cm


def body(geometry: GridGeometry, x: float, y: float, height: float = 1.7) -> np.ndarray:
    """Cells (P, 3) of an upright elliptic cylinder (semi-axes 18 x 13 cm) standing at x, y m."""
    cell = geometry.cell[0]
    xs = (np.arange(geometry.shape[0]) + 0.5) * cell
    ys = (np.arange(geometry.shape[1]) + 0.5) * cell
    footprint = np.argwhere(((xs[:, None] - x) / 0.18) ** 2 + ((ys[None] - y) / 0.13) ** 2 <= 1)
    layers = int(height / cell)
    return np.concatenate(
        [np.column_stack([footprint, np.full(len(footprint), k)]) for k in range(layers)]
    )


@pytest.mark.parametrize(
    ("n0", "n1", "expected", "with_f"),
    [(3, 6, 0.6667, 0.44444), (6, 3, 0.6667, 0.22222), (5, 4, 0.8889, None), (4, 5, 0.8889, None)],
)
def test_surface_likelihood_gives_the_thesis_worked_values(n0, n1, expected, with_f):
    assert surface_weight(n1, n0 + n1) == pytest.approx(expected, abs=1e-4)
    if with_f is not None:
        assert surface_weight(n1, n0 + n1, foreground_factor=True) == pytest.approx(with_f, 1e-4)
    # the compiled kernel on a 3 x 3 neighbourhood holding n1 foreground cells
    dense = np.zeros((3, 3, 1), np.uint8)
    dense.reshape(-1)[:n1] = 1
    out = np.empty(1)
    radius = np.array([1, 1, 0])
    _surface_weights(np.array([[1, 1, 0]]), dense, radius, False, out)
    assert out[0] == pytest.approx(expected, abs=1e-4)


def test_vertical_opening_keeps_runs_of_five_and_drops_thin_clutter():
    geometry = GridGeometry((10, 10, 20), (0.02,) * 3)
    column = [(2, 2, k) for k in range(5)]  # a run of exactly 5
    short = [(6, 6, k) for k in range(3, 7)]  # 4: removed
    slab = [(i, j, 15) for i in range(4) for j in range(4)]  # a horizontal slab: removed
    grid = OccupancyGrid.from_cells(geometry, np.array(column + short + slab)).opened(5)
    assert sorted(map(tuple, grid.cells)) == column
    assert grid.dense.sum() == 5


def test_a_mask_lists_its_pixels_as_argwhere_does():
    mask = (np.random.default_rng(3).random((48, 64)) < 0.2).astype(np.uint8)
    grid = OccupancyGrid.from_mask(mask, GridGeometry((64, 48, 1), (1.0, 1.0, 1.0), vertical=1))
    assert np.array_equal(grid.cells, np.argwhere(mask.T[:, :, None]))
    assert grid.cells.dtype == np.int64


def test_cells_outside_the_grid_and_repeats_are_dropped():
    geometry = GridGeometry((4, 4, 4), (1.0,) * 3)
    grid = OccupancyGrid.from_cells(
        geometry, np.array([[1, 1, 1], [1, 1, 1], [9, 0, 0], [-1, 0, 0]])
    )
    assert grid.cells.tolist() == [[1, 1, 1]]


def test_components_count_their_cells_and_measure_their_extent():
    a, b = body(ROOM, 1.0, 1.0), body(ROOM, 3.0, 4.0, height=0.5)
    found = components(OccupancyGrid.from_cells(ROOM, np.concatenate([a, b])), factor=4)
    assert sorted(found.counts.tolist()) == sorted([len(a), len(b)])
    first = int(np.argmax(found.counts == len(a)))
    assert found.centroids[first] == pytest.approx([1.0, 1.0, 0.85], abs=0.01)
    assert found.highs[first, 2] - found.lows[first, 2] == pytest.approx(1.7, abs=0.021)


def test_propagation_puts_at_most_one_particle_in_a_cell():
    dense = np.zeros((20, 20, 20), np.uint8)
    cells = np.full((300, 3), 10, np.int64)  # every particle in one cell
    stamp = np.zeros(dense.shape, np.int32)
    offsets = np.array(
        sorted(
            ((a, b, c) for a in range(-2, 3) for b in range(-2, 3) for c in range(-2, 3)),
            key=lambda o: o[0] ** 2 + o[1] ** 2 + o[2] ** 2,
        )[1:]
    )
    _snap_unique(cells, stamp, 1, offsets, dense, False)
    assert len(np.unique(cells, axis=0)) == 125  # the cell and all 124 within reach 2
    assert np.abs(cells - 10).max() <= 2


def test_jitter_is_the_room_over_the_cube_root_of_n_with_the_vertical_doubled():
    widths = jitter_widths(OccupancyFilterConfig(particles=300), ROOM)
    assert widths == pytest.approx(np.array([4.0, 5.0, 2 * 2.1]) / 300 ** (1 / 3))


def walk(config: OccupancyFilterConfig, gap: float, frames: int = 60) -> list:
    """Two people walking towards each other along x, `gap` m apart in y; they pass side by side
    (touching at 0.3 m) and go on; the steps of the filters."""
    filters = OccupancyParticleFilters(config)
    steps = []
    for f in range(frames):
        a, b = body(ROOM, 1.0 + 0.02 * f, 2.0), body(ROOM, 3.0 - 0.02 * f, 2.0 + gap)
        steps.append(filters.step(OccupancyGrid.from_cells(ROOM, np.concatenate([a, b]))))
    return steps


def test_blocking_keeps_two_people_in_contact_apart_and_without_it_one_filter_is_deleted():
    with_blocking = walk(OccupancyFilterConfig(), gap=0.4)
    last = with_blocking[-1]
    assert last.ids.tolist() == [1, 2] and not with_blocking[-1].deleted.any()
    x = 1.0 + 0.02 * 59
    assert last.estimates[0, :2] == pytest.approx([x, 2.0], abs=0.15)  # 1 went on to the right
    assert last.estimates[1, :2] == pytest.approx([4.0 - x, 2.4], abs=0.15)  # 2 to the left
    without = walk(OccupancyFilterConfig(blocking=False), gap=0.4)
    assert any(s.deleted.any() for s in without), "without blocking the filters coalesce"
    assert len(without[-1].ids) - without[-1].deleted.sum() == 1


def test_a_filter_starts_on_a_person_sized_blob_away_from_other_filters_only():
    config = OccupancyFilterConfig()
    filters = OccupancyParticleFilters(config)
    small = body(ROOM, 3.0, 4.0, height=0.4)  # shorter than 60 cm
    first = filters.step(OccupancyGrid.from_cells(ROOM, np.concatenate([body(ROOM, 1, 1), small])))
    assert first.started.sum() == 1 and first.estimates[0, :2] == pytest.approx([1, 1], abs=0.01)
    near = np.concatenate([body(ROOM, 1, 1), body(ROOM, 1.0, 1.5)])  # 50 cm away: excluded
    assert filters.step(OccupancyGrid.from_cells(ROOM, near)).started.sum() == 0


def test_a_filter_whose_person_vanishes_starves_and_is_deleted():
    config = OccupancyFilterConfig(starve_frames=4)
    filters = OccupancyParticleFilters(config)
    filters.step(OccupancyGrid.from_cells(ROOM, body(ROOM, 2, 2)))
    empty = OccupancyGrid.from_cells(ROOM, np.zeros((0, 3)))
    deleted = [bool(filters.step(empty).deleted.any()) for _ in range(4)]
    assert deleted == [False, False, False, True] and len(filters) == 0


def test_a_replay_gives_the_same_estimates():
    first, second = walk(OccupancyFilterConfig(), 0.4, 20), walk(OccupancyFilterConfig(), 0.4, 20)
    for a, b in zip(first, second, strict=True):
        assert np.array_equal(a.estimates, b.estimates)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_on_masks_two_walkers_passing_each_other_keep_their_tracks_and_boxes(seed):
    """Two 30 x 90 px people walk past each other 40 px apart vertically through a 2x-zoomed
    view; each keeps its id and, once confirmed, its box (IoU >= 0.5)."""
    tracker = METHOD.build(METHOD.defaults() | {"seed": seed}, 1)
    window = Rect(100.0, 50.0, 160.0, 240.0)  # scene px seen by a 320 x 480 camera image
    ids_seen: dict[int, set[int]] = {0: set(), 1: set()}
    matched = 0
    for k in range(25):
        mask = np.zeros((480, 320), np.uint8)
        truth = [(110 + 5 * k, 60, 30, 90), (230 - 5 * k, 190, 30, 90)]  # scene px x, y, w, h
        for x, y, w, h in truth:
            u, v = int((x - window.x) * 2), int((y - window.y) * 2)
            mask[v : v + 2 * h, max(u, 0) : u + 2 * w] = 1
        boxes = np.array(truth, dtype=float)  # the detector's blobs
        detections = Detections(
            boxes[:, :2] + boxes[:, 2:] / 2, boxes[:, 2] * boxes[:, 3], boxes, np.ones(2)
        )
        tracks = tracker.step(Observation(0.1 * k, detections, mask=mask, window=window))
        confirmed = tracks.status != TrackStatus.TENTATIVE
        for person, box in enumerate(truth):
            overlap = iou_matrix(np.array(box, float), tracks.bboxes[confirmed])[0]
            if len(overlap) and overlap.max() >= 0.5:
                ids_seen[person].add(int(tracks.ids[confirmed][np.argmax(overlap)]))
                matched += k >= 5
    assert ids_seen == {0: {1}, 1: {2}}
    assert matched >= 0.9 * 2 * 20


def test_the_method_config_makes_the_filters_and_the_blob_rules():
    config = OccupancyTrackerConfig(surface_radius=2, propagation="ranking", min_area=100.0, seed=4)
    tracker = OccupancyTracker(config, first_id=3)
    assert tracker.config.radius == (2, 2, 0) and tracker.config.seed == 4
    assert tracker.config.propagation.value == "ranking" and not tracker.config.initiation
    assert tracker.rules.min_area == 100.0 and tracker.rules.max_misses == config.max_misses
    assert tracker.next_id == 3
    with pytest.raises(ValueError, match="particles"):
        OccupancyTrackerConfig(particles=0)


def step_one_blob(tracker, k: int, box: tuple[float, float, float, float], window: Rect):
    """One frame of a 1:1 view whose mask and detector blob are `box` (scene px)."""
    mask = np.zeros((int(window.height), int(window.width)), np.uint8)
    x, y, w, h = (int(v) for v in box)
    mask[y - int(window.y) : y - int(window.y) + h, x - int(window.x) : x - int(window.x) + w] = 1
    boxes = np.array([box], dtype=float)
    found = Detections(boxes[:, :2] + boxes[:, 2:] / 2, boxes[:, 2] * boxes[:, 3], boxes, [1.0])
    return tracker.step(Observation(0.1 * k, found, mask=mask, window=window))


def test_a_speck_left_where_a_walker_was_does_not_measure_their_filter_which_is_then_lost():
    """A walker leaves; a 12 x 10 px speck (a ghost, a shadow) stays where they were: it is under
    a quarter of the filter's box, so the filter gets no hits from it and is deleted after
    max_misses frames, reported LOST once; with the gate off it lives on the speck."""

    def run(size_gate: float) -> list:
        values = METHOD.defaults() | {"size_gate": size_gate, "max_misses": 5}
        tracker = METHOD.build(values, 1)
        window = Rect(0.0, 0.0, 200.0, 200.0)
        out = [
            step_one_blob(tracker, k, (40.0 + 4 * k, 50.0, 30.0, 90.0), window) for k in range(15)
        ]
        out += [
            step_one_blob(tracker, k, (104.0, 125.0, 12.0, 10.0), window) for k in range(15, 30)
        ]
        return out

    gated = run(0.25)
    assert gated[14].status[0] == TrackStatus.CONFIRMED
    statuses = [(int(t.ids[0]), t.status[0]) if len(t) else None for t in gated[15:]]
    assert statuses[:4] == [(1, TrackStatus.COASTING)] * 4
    assert statuses[4] == (1, TrackStatus.LOST)
    assert all(s is None for s in statuses[5:])
    open_gate = run(0.0)
    assert all(len(t) == 1 and t.ids[0] == 1 for t in open_gate[15:])
    assert all(t.status[0] == TrackStatus.CONFIRMED for t in open_gate[16:])


def test_after_the_warm_up_a_replay_compiles_nothing():
    """The node calls `METHOD.warm_up` before it subscribes: every kernel the 2-D step uses is
    compiled (or loaded) then, so no frame of a lockstep replay waits for numba (a fresh install's
    first replay used to stall 9 s, time out the lockstep and give other tracks)."""
    numba = pytest.importorskip("numba")
    from tracker_filter.occupancy import occupancy_grid, occupancy_particles

    def signatures() -> dict[str, int]:
        return {
            f"{module.__name__}.{name}": len(kernel.signatures)
            for module in (occupancy_grid, occupancy_particles)
            for name, kernel in vars(module).items()
            if isinstance(kernel, numba.core.registry.CPUDispatcher)
        }

    assert METHOD.warm_up is not None
    METHOD.warm_up()
    before = signatures()
    tracker = METHOD.build(METHOD.defaults(), 1)
    window = Rect(0.0, 0.0, 200.0, 200.0)
    for k in range(12):  # two walkers crossing: blocking, a shared blob split
        mask = np.zeros((200, 200), np.uint8)
        boxes = np.array([[20.0 + 8 * k, 40.0, 30, 90], [150.0 - 8 * k, 60.0, 30, 90]])
        for x, y, w, h in boxes.astype(int):
            mask[y : y + h, x : x + w] = 1
        found = Detections(
            boxes[:, :2] + boxes[:, 2:] / 2, boxes[:, 2] * boxes[:, 3], boxes, [1, 1]
        )
        tracker.step(Observation(0.1 * k, found, mask=mask, window=window))
    assert len(tracker.filters) >= 2
    assert signatures() == before
