"""The learned height of followed objects by image row (object_scale), and the confirmation rule
that uses it: clutter far smaller than a person where it stands is not confirmed."""

import math

import numpy as np
import pytest

from tracker_filter.gated_hungarian.config import TrackerConfig
from tracker_filter.object_scale import NARROWEST, ExpectedHeight, HeightByRow, robust_line
from tracker_filter.observation import Detections, Observation
from tracker_filter.tracking import TrackStatus


def _ground_plane_boxes(rng: np.random.Generator, count: int) -> np.ndarray:
    """People on a ground plane: height 0.5 x (bottom row - 100) px, +-5 % noise."""
    bottoms = rng.uniform(200.0, 560.0, count)
    heights = 0.5 * (bottoms - 100.0) * rng.uniform(0.95, 1.05, count)
    widths = 0.4 * heights
    return np.column_stack([rng.uniform(0, 700, count), bottoms - heights, widths, heights])


def test_the_line_is_found_through_outliers():
    rng = np.random.default_rng(1)
    x = rng.uniform(0, 500, 200)
    y = 20.0 + 0.3 * x + rng.normal(0, 1.0, 200)
    y[:30] = rng.uniform(0, 10, 30)  # legs lost, tape joined: 15 % of the boxes far off
    intercept, slope = robust_line(x, y)
    assert intercept == pytest.approx(20.0, abs=2.5) and slope == pytest.approx(0.3, abs=0.01)
    naive = np.polyfit(x, y, 1)
    assert abs(naive[0] - 0.3) > 0.03  # plain least squares is pulled away


def test_nothing_is_required_until_enough_boxes_were_seen():
    scale = HeightByRow(0.5, min_samples=30)
    boxes = _ground_plane_boxes(np.random.default_rng(2), 60)
    scale.observe(boxes[:29])
    assert scale.line is None and scale.least_heights(boxes).tolist() == [0.0] * 60
    scale.observe(boxes[29:])
    query = np.array([[0.0, 300.0, 20.0, 100.0], [0.0, 0.0, 5.0, 50.0]])  # bottoms 400, 50
    assert scale.expected_heights(query) == pytest.approx([150.0, 0.0], abs=5.0)  # 0 above horizon
    assert scale.least_heights(query)[0] == pytest.approx(75.0, abs=2.5)
    scale.clear()
    assert len(scale) == 0 and scale.line is None


def test_a_line_no_camera_above_the_ground_gives_is_not_taken():
    """The first boxes of a scene: two people at the view's edge, the lower one cut off by it, so
    the boxes shrink with the row. That line is refused (none yet); boxes of a ground plane then
    give one, and a later falling fit leaves it as it was."""
    scale = HeightByRow(0.5, min_samples=30, refit_every=10)
    rows = np.linspace(200.0, 400.0, 30)
    heights = 300.0 - 0.5 * rows  # falling with the row
    falling = np.column_stack([np.zeros(30), rows - heights, np.full(30, 20.0), heights])
    scale.observe(falling)
    assert scale.line is None and scale.least_heights(falling).tolist() == [0.0] * 30
    scale.observe(_ground_plane_boxes(np.random.default_rng(3), 200))
    kept = scale.line
    assert kept is not None and kept[1] > 0
    scale.observe(np.repeat(falling, 20, axis=0)[:600])
    assert scale.line == kept


def test_bad_settings_are_refused():
    with pytest.raises(ValueError):
        HeightByRow(1.5)
    with pytest.raises(ValueError):
        HeightByRow(0.5, min_samples=1)
    with pytest.raises(ValueError, match="confirm_height_ratio"):
        TrackerConfig.preset("multi", confirm_height_ratio=-0.1)


def _walker_boxes(x0: float, bottom: float, height: float, frames: int) -> list[np.ndarray]:
    return [np.array([x0 + 5.0 * k, bottom - height, 0.4 * height, height]) for k in range(frames)]


def _run(tracker, per_frame: list[list[np.ndarray]]) -> list:
    sets = []
    for k, boxes in enumerate(per_frame):
        box = np.array(boxes).reshape(-1, 4)
        detections = Detections(
            box[:, :2] + box[:, 2:] / 2, box[:, 2] * box[:, 3], box, np.zeros(len(box))
        )
        sets.append(tracker.step(Observation(k * 0.1, detections)))
    return sets


def _confirmed_heights(sets: list) -> set[int]:
    return {
        int(round(t.bboxes[i, 3]))
        for t in sets
        for i in np.flatnonzero(t.status == TrackStatus.CONFIRMED)
    }


@pytest.mark.parametrize("ratio, expected", [(0.5, {60, 120}), (0.0, {10, 60, 120})])
def test_a_drifting_patch_far_smaller_than_a_person_there_is_not_confirmed(ratio, expected):
    """Two walkers (120 px tall at row 400, 60 px at row 250) teach the rule the scene's scale;
    then a 10 px patch drifts steadily at row 400 (a ghost healing, a leaf) and a third walker,
    60 px tall, enters at row 250: the walker is confirmed, the patch is not (it is with the
    rule off)."""
    rules = {"confirm_travel": 12.0, "confirm_straightness": 0.7, "confirm_height_ratio": ratio}
    tracker = TrackerConfig.preset("multi", **rules).build_tracker()
    near, far = _walker_boxes(50, 400, 120, 60), _walker_boxes(400, 250, 60, 60)
    newcomer, patch = _walker_boxes(100, 250, 60, 30), _walker_boxes(600, 400, 10, 30)
    frames = [[near[k], far[k]] for k in range(30)]
    frames += [[near[30 + k], far[30 + k], newcomer[k], patch[k]] for k in range(30)]
    assert _confirmed_heights(_run(tracker, frames)) == expected


def test_a_minimum_height_keeps_small_things_tentative():
    tracker = TrackerConfig.preset(
        "multi", confirm_travel=12.0, confirm_min_height=30.0
    ).build_tracker()
    frames = [
        [a, b]
        for a, b in zip(
            _walker_boxes(50, 400, 120, 20), _walker_boxes(600, 400, 20, 20), strict=True
        )
    ]
    assert _confirmed_heights(_run(tracker, frames)) == {120}


LINE = (-20.0, 0.5)  # a typical person: 30 px tall with their feet on row 100, 80 on row 200


def test_the_expected_height_passes_through_the_reference_and_keeps_the_horizon():
    child = np.array([10.0, 176.0, 12.0, 24.0])  # feet on row 200: 0.3 x the typical person
    expected = ExpectedHeight.through(LINE, child)
    assert expected is not None
    boxes = np.array([child, [0.0, 60.0, 5.0, 40.0]])  # and a box with its feet on row 100
    np.testing.assert_allclose(expected.heights(boxes), [24.0, 0.3 * 30.0])
    assert -expected.intercept / expected.slope == pytest.approx(40.0)  # the line's horizon
    # a reference standing above the horizon says nothing
    assert ExpectedHeight.through(LINE, np.array([0.0, 0.0, 5.0, 30.0])) is None


def test_a_window_sees_the_same_heights_as_the_scene():
    """A reference seen in a window whose top is scene row 50, and boxes in another window whose
    top is row 80: the heights are the scene's."""
    in_scene = np.array([10.0, 150.0, 20.0, 50.0])
    scene = ExpectedHeight.through(LINE, in_scene)
    seen = ExpectedHeight.through(LINE, in_scene - [0.0, 50.0, 0.0, 0.0], row_offset=50.0)
    assert scene is not None and seen is not None
    later = np.array([[0.0, 100.0, 10.0, 30.0], [5.0, 20.0, 10.0, 60.0]])  # rows of window 2
    np.testing.assert_allclose(
        seen.shifted(80.0).heights(later), scene.heights(later + [0.0, 80.0, 0.0, 0.0])
    )


def test_the_likelihood_is_one_at_the_expected_height_and_falls_on_a_log_scale():
    expected = ExpectedHeight(60.0, 0.0)
    heights = [60.0, 60.0 * math.exp(0.1), 60.0 * math.exp(-0.1), 30.0]
    boxes = np.array([[0.0, 0.0, 20.0, h] for h in heights])
    weights = expected.likelihood(boxes, spread=0.1)
    np.testing.assert_allclose(weights[:3], [1.0, math.exp(-0.5), math.exp(-0.5)])
    assert weights[3] < 1e-9  # half the height: a torso is not the person


def test_the_usual_aspect_is_a_low_quantile_of_the_boxes_width_over_height():
    """People 0.4 as wide as tall (a stride +-30 %), and a fifth of the boxes pairs in one blob:
    the aspect learned is one person's, not pulled up by the pairs."""
    rng = np.random.default_rng(4)
    boxes = _ground_plane_boxes(rng, 200)
    boxes[:, 2] *= rng.uniform(0.7, 1.3, 200)
    boxes[:40, 2] *= 2.0
    scale = HeightByRow(0.5)
    assert scale.aspect is None
    scale.observe(boxes)
    assert scale.aspect == pytest.approx(0.4, abs=0.04)
    scale.clear()
    assert scale.aspect is None


def test_the_aspect_prior_spares_narrow_boxes_down_to_a_quarter_of_the_usual_aspect():
    """A box narrower than the usual aspect (mid-stride, partly hidden) costs nothing down to
    NARROWEST of it; a wider one, or one narrower still (a post), falls on a log scale; without a
    known aspect, or with the spread 0, only the height counts."""
    expected = ExpectedHeight(60.0, 0.0, aspect=0.4)
    quarter = 60.0 * 0.4 * NARROWEST
    widths = [quarter, 12.0, 24.0, 24.0 * math.exp(0.15), 48.0, quarter * math.exp(-0.15), 2.0]
    boxes = np.array([[0.0, 0.0, w, 60.0] for w in widths])
    weights = expected.likelihood(boxes, spread=0.1, aspect_spread=0.15)
    np.testing.assert_allclose(weights[:4], [1.0, 1.0, 1.0, math.exp(-0.5)])
    assert weights[4] < 1e-4  # twice as wide: two people
    np.testing.assert_allclose(weights[5], math.exp(-0.5))
    assert weights[6] < 1e-4  # 2 px wide: a post
    np.testing.assert_allclose(expected.likelihood(boxes, spread=0.1), 1.0)
    unknown = ExpectedHeight(60.0, 0.0)
    np.testing.assert_allclose(unknown.likelihood(boxes, spread=0.1, aspect_spread=0.15), 1.0)
    assert expected.shifted(10.0).aspect == 0.4 and unknown.with_aspect(0.3).aspect == 0.3
