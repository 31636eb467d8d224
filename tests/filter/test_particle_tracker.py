"""Seed 003's multi-target colour tracker (`colour_particles`): targets started from detections
and from a drawn rectangle follow people through a moving camera window in scene px, a target that
stops moving stays tracked, and a replay gives the same tracks."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from tracker_filter.observation import Detections, Need, Observation
from tracker_filter.particles.particle_tracker import COAST_NOISE, ColourParticleTracker
from tracker_filter.trackers import TRACKERS
from tracker_filter.tracking import TrackStatus
from tracker_msgs_py.geometry import Rect

DT = 0.1
SCENE = (240, 480)  # height, width


def scene_frames(count: int, stop_after: int = 1000):
    """Two people on a textured street (scene px): red-blue walking right 3 px per frame (until
    `stop_after`), green-yellow walking left; the camera window pans 1 px per frame."""
    rng = np.random.default_rng(0)
    street = rng.integers(80, 140, size=(*SCENE, 3), dtype=np.uint8)
    frames = []
    for k in range(count):
        scene = street.copy()
        a = (60 + 3 * min(k, stop_after), 80)
        b = (360 - 3 * k, 90)
        scene[a[1] : a[1] + 30, a[0] : a[0] + 20] = (40, 40, 210)
        scene[a[1] + 30 : a[1] + 60, a[0] : a[0] + 20] = (170, 60, 30)
        scene[b[1] : b[1] + 30, b[0] : b[0] + 20] = (40, 200, 40)
        scene[b[1] + 30 : b[1] + 60, b[0] : b[0] + 20] = (30, 200, 220)
        window = Rect(float(k), 0.0, 400.0, 240.0)
        image = scene[:, k : k + 400].copy()
        boxes = np.array([[a[0], a[1], 20, 60], [b[0], b[1], 20, 60]], dtype=float)
        detections = Detections(boxes[:, :2] + boxes[:, 2:] / 2, boxes[:, 2] * boxes[:, 3], boxes,
                                np.ones(2))  # fmt: skip
        moving = k < stop_after
        shown = detections if moving else detections.subset(np.array([1]))
        frames.append((Observation(k * DT, shown, True, image, None, window), boxes))
    return frames


def tracker(**overrides) -> ColourParticleTracker:
    values = TRACKERS.get("colour_particles").defaults() | {"particles": 300} | overrides
    return TRACKERS.get("colour_particles").build(values)


def iou(a: np.ndarray, b: np.ndarray) -> float:
    w = max(0.0, min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0]))
    h = max(0.0, min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1]))
    return w * h / (a[2] * a[3] + b[2] * b[3] - w * h)


def test_two_people_keep_their_ids_through_a_panning_window():
    t = tracker()
    history = [t.step(obs) for obs, _ in scene_frames(40)]
    last = history[-1]
    assert sorted(last.ids.tolist()) == [1, 2]
    assert (last.status == TrackStatus.CONFIRMED).all()
    truth = scene_frames(40)[-1][1]
    for i, box in zip(last.ids, last.bboxes, strict=True):
        assert iou(box, truth[i - 1]) > 0.5
    assert last.velocities[last.ids.tolist().index(1)][0] > 15  # ~30 px/s to the right


def test_a_person_who_stops_stays_tracked_without_detections():
    t = tracker()
    frames = scene_frames(50, stop_after=25)
    history = [t.step(obs) for obs, _ in frames]
    last, truth = history[-1], frames[-1][1]
    row = last.ids.tolist().index(1)
    assert last.status[row] == TrackStatus.CONFIRMED
    assert iou(last.bboxes[row], truth[0]) > 0.5


def test_a_target_without_detections_for_max_unsupported_is_lost():
    t = tracker(max_unsupported=1.0)
    frames = scene_frames(50, stop_after=25)  # person 1 stands still from 2.5 s on
    history = [t.step(obs) for obs, _ in frames]
    standing = [h.ids.tolist() for h in history[25:]]
    assert all(1 in ids for ids in standing[:10]), "kept for the first second"
    assert all(1 not in ids for ids in standing[12:]), "then lost"
    assert all(2 in ids for ids in standing), "the walker, still detected, is kept"


def test_a_drawn_rectangle_starts_a_confirmed_target():
    t = tracker()
    obs, truth = scene_frames(1)[0]
    blank = Observation(obs.time, Detections.empty(), True, obs.image, None, obs.window)
    assert t.seed(Rect(*truth[1]), blank) == 1
    tracks = t.step(Observation(0.1, Detections.empty(), True, obs.image, None, obs.window))
    assert tracks.ids.tolist() == [1] and tracks.status[0] == TrackStatus.CONFIRMED
    assert t.seed(Rect(*truth[1]), Observation(0.2)) is None  # no image: nothing to start on


def test_a_replay_gives_the_same_tracks_and_another_seed_does_not():
    def run(seed: int) -> np.ndarray:
        t = tracker(seed=seed)
        return np.concatenate([t.step(obs).means for obs, _ in scene_frames(15)])

    np.testing.assert_array_equal(run(1), run(1))
    assert not np.array_equal(run(1), run(2))


def with_masks(frames):
    """The frames' observations with the detector's motion mask: each person's box, image px."""
    out = []
    for observation, boxes in frames:
        mask = np.zeros(observation.image.shape[:2], np.uint8)
        shift = observation.window.x
        for x, y, w, h in boxes:
            mask[int(y) : int(y + h), max(int(x - shift), 0) : max(int(x + w - shift), 0)] = 255
        out.append((replace(observation, mask=mask), boxes))
    return out


def test_the_foreground_cue_needs_the_mask_and_keeps_the_people():
    assert Need.MASK not in tracker(foreground_power=0.0).needs
    t = tracker()  # the defaults: foreground cue on
    assert t.needs == {Need.IMAGE, Need.WINDOW, Need.MASK}
    frames = with_masks(scene_frames(40))
    history = [t.step(obs) for obs, _ in frames]
    last, truth = history[-1], frames[-1][1]
    assert sorted(last.ids.tolist()) == [1, 2]
    for i, box in zip(last.ids, last.bboxes, strict=True):
        assert iou(box, truth[i - 1]) > 0.5
    # a frame whose mask was lost in transport: the filters go on by colour alone
    lost = replace(frames[-1][0], time=4.0, mask=None)
    assert sorted(t.step(lost).ids.tolist()) == [1, 2]


def test_the_height_rule_keeps_targets_smaller_than_people_unconfirmed():
    """The multi tracker's height rule: a 60 px person is confirmed when 50 px are asked for,
    not when 70 are."""

    def confirmed(**rule) -> bool:
        t = tracker(**rule)
        history = [t.step(obs) for obs, _ in scene_frames(20)]
        return bool((history[-1].status == TrackStatus.CONFIRMED).any())

    assert confirmed(confirm_min_height=50.0)
    assert not confirmed(confirm_min_height=70.0)


def test_the_height_prior_learns_the_ground_line_from_confirmed_targets():
    """Without the height rule the tracker keeps its own line for the prior; with the rule the
    prior shares the rule's. The two 60 px people give a flat line at 60 px."""
    t = tracker()  # the defaults: the prior on, the height rule off
    assert t.ground is not None and t.ground is not t.confirmation.scale
    frames = with_masks(scene_frames(40))
    history = [t.step(obs) for obs, _ in frames]
    assert t.ground.line is not None
    feet = np.array([[0.0, 100.0, 20.0, 60.0], [0.0, 90.0, 20.0, 60.0]])  # rows 160 and 150
    np.testing.assert_allclose(t.ground.expected_heights(feet), 60.0, atol=1.0)
    # each target's own height, from its start box and the detections that measured it, with
    # the people's usual aspect learned with the line (20 x 60 px boxes) for the aspect prior
    assert t.ground.aspect == pytest.approx(20.0 / 60.0, abs=0.02)
    for expected, box in zip(t._expected_heights(), feet, strict=True):
        assert expected is not None
        assert expected.heights(box[None])[0] == pytest.approx(60.0, abs=1.0)
        assert expected.aspect == t.ground.aspect
    last, truth = history[-1], frames[-1][1]
    for i, box in zip(last.ids, last.bboxes, strict=True):
        assert iou(box, truth[i - 1]) > 0.5
    shared = tracker(confirm_height_ratio=0.5)
    assert shared.ground is shared.confirmation.scale
    assert tracker(height_spread=0.0, confirm_height_ratio=0.0).ground is None


def test_the_coasting_randomness_is_a_parameter_and_a_quarter_by_default():
    assert tracker().config.coast_noise == COAST_NOISE == 0.25
    assert tracker(coast_noise=1.0).config.coast_noise == 1.0
