"""The particle filter's height prior: the expected height through a target's own box, in a
window's coordinates as in the scene's, and a filter that keeps most of a walker's height when
the motion mask loses their legs, where the foreground cue alone shrinks the box onto the torso."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tracker_filter.colour_particle import (
    RECOMMENDED_SIGMA,
    ColourParticleFilter,
    HistogramAppearance,
    ParticleFilterConfig,
)
from tracker_filter.foreground_cue import ForegroundCue, ForegroundMask
from tracker_filter.object_scale import ExpectedHeight

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


def walker_losing_legs(frames: int = 40, seed: int = 0):
    """A red-and-blue person walking towards the camera (50 -> 96 px tall, feet 2 px lower each
    frame, on the line 50 + 0.6 (row - 100)) over a textured background; from frame 10 the motion
    mask holds only their upper half (grey trousers on grey ground). Images, masks, true boxes."""
    rng = np.random.default_rng(seed)
    background = rng.integers(60, 160, size=(240, 240, 3), dtype=np.uint8)
    images, masks, boxes = [], [], []
    for k in range(frames):
        bottom = 100 + 2 * k
        height = 50 + 0.6 * (bottom - 100)
        width = 0.4 * height
        x0, y0 = round(120 - width / 2), round(bottom - height)
        x1, y1 = round(120 + width / 2), round(bottom)
        image = background.copy()
        waist = y0 + (y1 - y0) // 2
        image[y0:waist, x0:x1] = (40, 40, 200)
        image[waist:y1, x0:x1] = (150, 60, 30)
        noise = rng.integers(-10, 11, size=image.shape)
        images.append(np.clip(image.astype(int) + noise, 0, 255).astype(np.uint8))
        mask = np.zeros(image.shape[:2], np.uint8)
        mask[y0 : (waist if k >= 10 else y1), x0:x1] = 255
        masks.append(mask)
        boxes.append(np.array([x0, y0, x1 - x0, y1 - y0], float))
    return images, masks, boxes


FOREGROUND = ParticleFilterConfig(
    particles=300,
    sigma=tuple(8 * s for s in RECOMMENDED_SIGMA),
    size_noise=0.05,
    foreground=ForegroundCue(power=15.0),
)
WITH_PRIOR = ParticleFilterConfig(
    particles=300,
    sigma=FOREGROUND.sigma,
    size_noise=0.05,
    foreground=ForegroundCue(power=15.0),
    height_spread=0.1,
)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_prior_keeps_the_height_when_the_mask_loses_the_legs(seed: int):
    images, masks, truth = walker_losing_legs()
    # the line a tracker learns from other people: 10 % taller than this one
    line = (1.1 * (50 - 0.6 * 100), 1.1 * 0.6)

    def heights(config: ParticleFilterConfig) -> np.ndarray:
        f = ColourParticleFilter(
            images[0], truth[0], HistogramAppearance(background_weighting=True), config,
            np.random.default_rng(seed),
        )  # fmt: skip
        expected = ExpectedHeight.through(line, truth[0])
        found = [
            f.step(image, foreground=ForegroundMask.of(mask), height=expected).box[3]
            for image, mask in zip(images[1:], masks[1:], strict=True)
        ]
        return np.array(found[-10:]) / np.array([box[3] for box in truth[-10:]])

    # half the person is in the mask: the prior holds most of the height (the mask's fit and
    # the prior meet at about 3/4 of it), the mask alone shrinks the box onto the torso
    assert np.all(heights(WITH_PRIOR) > 0.68)
    assert np.mean(heights(FOREGROUND)) < 0.62


def test_a_bad_spread_is_refused():
    with pytest.raises(ValueError, match="height_spread"):
        ParticleFilterConfig(height_spread=-0.1)
    with pytest.raises(ValueError, match="height_spread"):
        ParticleFilterConfig(height_spread=float("nan"))
