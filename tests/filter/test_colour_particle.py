"""Seed 003's colour particle filter: the thesis's worked values, the histogram kernel against
plain NumPy, reproducibility, and tracking a coloured person on a textured background."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from tracker_filter.colour_histograms import (
    ColourSpace,
    bin_count,
    bin_image,
    clip_bounds,
    coefficients,
    coefficients_reference,
    histogram,
    ring_coefficients,
    ring_coefficients_reference,
)
from tracker_filter.object_scale import ExpectedHeight
from tracker_filter.particles.colour_particle import (
    RECOMMENDED_SIGMA,
    ColourParticleFilter,
    CovarianceAppearance,
    HistogramAppearance,
    ParticleFilterConfig,
    Resampling,
    WeightCorrection,
    corrected_weights,
    in_perspective,
    resample,
    seen_part,
    static_noise_share,
    top_parts,
)
from tracker_filter.particles.foreground_cue import ForegroundCue, ForegroundMask
from tracker_filter.particles.region_covariance import (
    RIDGE,
    forstner_distances,
    integral_features,
    region_covariances,
)


def test_sigmoid_correction_gives_the_thesis_values():
    config = ParticleFilterConfig(correction=WeightCorrection.SIGMOID)
    got = corrected_weights(np.array([0.61, 0.75, 0.25]), config)
    np.testing.assert_allclose(got, [0.893, 0.998, 0.002], atol=5e-4)


def test_linear_and_exponential_corrections():
    w = np.array([0.2, 0.5, 0.8])
    linear = corrected_weights(w, ParticleFilterConfig(correction=WeightCorrection.LINEAR))
    np.testing.assert_allclose(linear, [0.1, 0.55, 1.0])
    flat = corrected_weights(np.full(3, 0.4), ParticleFilterConfig(correction="linear"))
    np.testing.assert_array_equal(flat, np.ones(3))
    exponential = corrected_weights(w, ParticleFilterConfig(correction="exponential"))
    np.testing.assert_allclose(exponential, np.exp(-10 * (1 - w)))


def test_adaptive_noise_share_gives_the_thesis_values():
    got = [static_noise_share(s) for s in (0.4, 0.3, 0.2)]
    np.testing.assert_allclose(got, [0.002, 0.5, 0.998], atol=5e-4)


@pytest.mark.parametrize("space", list(ColourSpace))
def test_kernel_equals_one_numpy_histogram_per_rectangle(space):
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, size=(120, 160, 3), dtype=np.uint8)
    bins = bin_image(image, space, 16)
    count = bin_count(space, 16)
    assert bins.min() >= 0 and bins.max() < count
    refs = np.sqrt(np.stack([histogram(bins, b, count) for b in ([10, 10, 40, 60], [0, 0, 5, 5])]))
    boxes = np.column_stack(
        [rng.uniform(-20, 150, 300), rng.uniform(-20, 110, 300), rng.uniform(0, 60, (300, 2))]
    )
    bounds = clip_bounds(boxes, image.shape)
    which = rng.integers(0, 2, 300)
    fast = coefficients(bins, bounds, refs, which)
    np.testing.assert_allclose(fast, coefficients_reference(bins, bounds, refs, which), atol=1e-12)
    empty = (bounds[:, 2] == bounds[:, 0]) | (bounds[:, 3] == bounds[:, 1])
    assert empty.any() and np.all(fast[empty] == 0.0)
    assert coefficients(bins, bounds[:1] * 0 + [10, 10, 40, 60], refs, [0])[0] == pytest.approx(1.0)


def test_ring_kernel_equals_numpy_over_the_ring_pixels():
    rng = np.random.default_rng(1)
    image = rng.integers(0, 256, size=(120, 160, 3), dtype=np.uint8)
    bins = bin_image(image, ColourSpace.RGB, 16)
    reference = np.sqrt(histogram(bins, [10, 10, 40, 60], bin_count(ColourSpace.RGB, 16)))
    boxes = np.column_stack(
        [rng.uniform(-20, 150, 200), rng.uniform(-20, 110, 200), rng.uniform(0, 60, (200, 2))]
    )
    grown = boxes + np.column_stack([-0.3 * boxes[:, 2:], 0.6 * boxes[:, 2:]])
    inner, outer = clip_bounds(boxes, image.shape), clip_bounds(grown, image.shape)
    for stride in (2, 1):
        fast = ring_coefficients(bins, inner, outer, reference, stride)
        np.testing.assert_allclose(
            fast, ring_coefficients_reference(bins, inner, outer, reference, stride), atol=1e-12
        )
    ring_pixels = np.prod(outer[:, 2:] - outer[:, :2], axis=1) - np.prod(
        inner[:, 2:] - inner[:, :2], axis=1
    )
    empty = ring_pixels == 0
    assert empty.any() and np.all(fast[empty] == 0.0)


def test_contrast_scores_a_box_shrunk_inside_the_person_below_the_right_one():
    """A plain colour histogram scores a box inside the person as well as the person's box; with
    the contrast cue the ring around the inner box, itself the person, gives it away."""
    rng = np.random.default_rng(4)
    image = np.clip(rng.normal(120, 8, size=(200, 300, 3)), 0, 255).astype(np.uint8)
    image[50:150, 130:170] = (30, 30, 200)  # the person, 40 x 100 px
    right, shrunk = np.array([130.0, 50, 40, 100]), np.array([140.0, 75, 20, 50])
    plain, contrasted = HistogramAppearance(), HistogramAppearance(contrast=1.0)
    for appearance in (plain, contrasted):
        appearance.reference(image, right)
    on_right, on_shrunk = plain.similarities(image, np.stack([right, shrunk]))
    assert on_shrunk >= on_right - 0.01
    on_right, on_shrunk = contrasted.similarities(image, np.stack([right, shrunk]))
    assert on_right > 0.8 and on_shrunk < 0.1


def test_region_covariances_equal_numpys_over_the_pixels():
    rng = np.random.default_rng(3)
    image = rng.integers(0, 256, size=(50, 70, 3), dtype=np.uint8)
    integral = integral_features(image)
    bounds = np.array([[0, 0, 70, 50], [5, 7, 20, 30], [60, 40, 61, 41], [3, 3, 5, 9]])
    got = region_covariances(integral, bounds)
    for (x0, y0, x1, y1), covariance in zip(bounds, got, strict=True):
        ys, xs = np.mgrid[y0:y1, x0:x1]
        patch = image[y0:y1, x0:x1]
        f = np.stack([xs, ys, patch[..., 2], patch[..., 1], patch[..., 0]], -1).reshape(-1, 5)
        expected = np.cov(f.T.astype(float), bias=True) + RIDGE * np.eye(5)
        np.testing.assert_allclose(covariance, expected, rtol=1e-9, atol=1e-7)


def test_forstner_distance_is_the_generalised_eigenvalues_log_norm():
    from scipy.linalg import eigh

    rng = np.random.default_rng(4)
    a = rng.normal(size=(3, 5, 5))
    covariances = a @ a.transpose(0, 2, 1) + np.eye(5)
    reference = covariances[0]
    got = forstner_distances(covariances, reference)
    for c, rho in zip(covariances, got, strict=True):
        expected = np.sqrt(np.sum(np.log(eigh(c, reference, eigvals_only=True)) ** 2))
        assert rho == pytest.approx(expected, rel=1e-9, abs=1e-9)
    assert got[0] == pytest.approx(0.0, abs=1e-9)
    # symmetric, and unchanged by a common congruence (affine invariance)
    assert forstner_distances(covariances[:1], covariances[1])[0] == pytest.approx(got[1])
    t = rng.normal(size=(5, 5)) + 3 * np.eye(5)
    moved = forstner_distances(t @ covariances @ t.T, t @ reference @ t.T)
    np.testing.assert_allclose(moved, got, rtol=1e-7, atol=1e-7)


def test_resampling_follows_the_weights():
    rng = np.random.default_rng(1)
    weights = np.array([0.0, 0.1, 0.6, 0.3])
    for rule in Resampling:
        picks = np.concatenate([resample(weights, rule, rng) for _ in range(500)])
        shares = np.bincount(picks, minlength=4) / len(picks)
        np.testing.assert_allclose(shares, weights, atol=0.01)
    # systematic: every particle of weight w is drawn floor(N w) or ceil(N w) times
    counts = np.bincount(resample(np.array([0.25, 0.25, 0.5]), Resampling.SYSTEMATIC, rng))
    assert counts.tolist() in ([1, 1, 1], [0, 1, 2], [1, 0, 2])


SHIRT, TROUSERS = (40, 40, 200), (150, 60, 30)  # bgr


def draw_person(image: np.ndarray, x: int, y: int, shirt: tuple[int, int, int] = SHIRT) -> None:
    """A 30 x 80 px person, shirt over trousers, with their top-left corner at (x, y)."""
    image[y : y + 40, x : x + 30] = shirt
    image[y + 40 : y + 80, x : x + 30] = TROUSERS


def with_sensor_noise(image: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The image with uniform noise of +-12 grey levels per channel, clipped to uint8."""
    noise = rng.integers(-12, 13, size=image.shape)
    return np.clip(image.astype(int) + noise, 0, 255).astype(np.uint8)


def textured_scene(frames: int, seed: int = 0):
    """A red-shirted, blue-trousered 30 x 80 px person walking 2 px/frame right and 0.5 px/frame
    down over a textured grey-green background; returns images and true boxes (x, y, w, h)."""
    rng = np.random.default_rng(seed)
    background = rng.integers(60, 160, size=(240, 320, 3), dtype=np.uint8)
    background[..., 1] = np.clip(background[..., 1].astype(int) + 30, 0, 255)
    images, boxes = [], []
    for k in range(frames):
        x, y = 40.0 + 2.0 * k, 60.0 + 0.5 * k
        image = background.copy()
        xi, yi = round(x), round(y)
        draw_person(image, xi, yi)
        images.append(with_sensor_noise(image, rng))
        boxes.append(np.array([xi, yi, 30.0, 80.0]))
    return images, boxes


def iou(a: np.ndarray, b: np.ndarray) -> float:
    w = max(0.0, min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0]))
    h = max(0.0, min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1]))
    inter = w * h
    return inter / (a[2] * a[3] + b[2] * b[3] - inter)


BASELINE = ParticleFilterConfig(particles=300, correction="none", adaptive_noise=False)
FINAL = ParticleFilterConfig(particles=300)


@pytest.mark.parametrize(
    ("appearance", "config", "settled_iou"),
    [
        (HistogramAppearance(), FINAL, 0.8),
        # without V, the shirt's and trousers' hues also fit a box shifted up or down a little
        (HistogramAppearance(ColourSpace.HSV), FINAL, 0.6),
        (HistogramAppearance(regions=3), FINAL, 0.8),
        # the thesis ran Ext 5 on the baseline; exp(-rho) is far sharper than a Bhattacharyya
        # coefficient (0.08 one frame in), so the final algorithm's sigmoid zeroes every weight
        (CovarianceAppearance(), BASELINE, 0.8),
    ],
    ids=["rgb", "hsv", "three regions", "covariance, baseline"],
)
def test_follows_a_walking_person(appearance, config: ParticleFilterConfig, settled_iou: float):
    images, truth = textured_scene(60)
    f = ColourParticleFilter(images[0], truth[0], appearance, config, np.random.default_rng(2))
    overlaps = [
        iou(f.step(image).box, box) for image, box in zip(images[1:], truth[1:], strict=True)
    ]
    # the state starts at rest (the thesis): the box lags until the particles' velocities have
    # grown to the walker's 2 px per frame, then stays on them
    assert min(overlaps) > 0.2
    assert np.mean(overlaps[-30:]) > settled_iou


def test_same_seed_same_run_and_another_seed_another_run():
    images, truth = textured_scene(15)

    def run(seed: int) -> np.ndarray:
        f = ColourParticleFilter(
            images[0],
            truth[0],
            HistogramAppearance(),
            ParticleFilterConfig(particles=200),
            np.random.default_rng(seed),
        )
        return np.array([f.step(image).box for image in images[1:]])

    np.testing.assert_array_equal(run(5), run(5))
    assert not np.array_equal(run(5), run(6))


def test_bad_start_boxes_and_parameters_are_refused():
    image = np.zeros((50, 50, 3), np.uint8)
    with pytest.raises(ValueError, match="start box"):
        ColourParticleFilter(
            image,
            [1, 1, 0, 5],
            HistogramAppearance(),
            ParticleFilterConfig(),
            np.random.default_rng(0),
        )
    with pytest.raises(ValueError, match="no pixels"):
        ColourParticleFilter(
            image,
            [80, 80, 5, 5],
            HistogramAppearance(),
            ParticleFilterConfig(),
            np.random.default_rng(0),
        )
    with pytest.raises(ValueError, match="particles"):
        ParticleFilterConfig(particles=0)
    with pytest.raises(ValueError, match="sigma"):
        ParticleFilterConfig(sigma=(1.0, 2.0))
    with pytest.raises(ValueError, match="occlusion_ratio"):
        ParticleFilterConfig(occlusion_ratio=1.0)
    with pytest.raises(ValueError, match="coast_noise"):
        ParticleFilterConfig(coast_noise=1.5)
    with pytest.raises(ValueError, match="settle_frames"):
        ParticleFilterConfig(settle_frames=-1)
    with pytest.raises(ValueError, match="upper_share"):
        ParticleFilterConfig(upper_share=1.0)


def test_background_weighting_tells_a_thin_person_from_the_street_around_them():
    """A box mostly of street around a thin red figure: its plain histogram also matches the bare
    street next to it; weighted by the surroundings, the street's colours count for little."""
    rng = np.random.default_rng(6)
    image = np.clip(rng.normal(120, 8, size=(200, 300, 3)), 0, 255).astype(np.uint8)
    image[60:140, 140:152] = (30, 30, 200)  # the figure: 12 of the box's 40 px width
    box, street = np.array([126.0, 60, 40, 80]), np.array([40.0, 60, 40, 80])
    plain, weighted = HistogramAppearance(), HistogramAppearance(background_weighting=True)
    for appearance in (plain, weighted):
        appearance.reference(image, box)
    assert plain.similarities(image, street[None])[0] > 0.7
    # only the reference is weighted (candidates keep their street pixels): the true box scores
    # well below 1 but far above the bare street
    on_street, on_box = weighted.similarities(image, np.stack([street, box]))
    assert on_street < 0.3 and on_box > 2 * on_street


def occluded_scene(seed: int = 0):
    """The textured scene's person walking 4 px/frame right behind a board hiding them
    completely for 11 frames (1.1 s at 10 fps) and partly for 7 frames either side."""
    rng = np.random.default_rng(seed)
    background = rng.integers(60, 160, size=(200, 320, 3), dtype=np.uint8)
    board = np.full((120, 70, 3), (150, 150, 150), np.uint8)
    images, boxes = [], []
    for k in range(60):
        image = background.copy()
        x = 10 + 4 * k
        draw_person(image, x, 40)
        image[20:140, 130:200] = board
        images.append(with_sensor_noise(image, rng))
        boxes.append(np.array([x, 40.0, 30.0, 80.0]))
    return images, boxes


def kept_after_the_board(config: ParticleFilterConfig, seed: int) -> tuple[bool, list]:
    """Whether the filter is on the person in most frames after they reappear whole, and its
    estimates."""
    images, truth = occluded_scene()
    f = ColourParticleFilter(
        images[0], truth[0], HistogramAppearance(), config, np.random.default_rng(seed)
    )
    estimates = [f.step(image) for image in images[1:]]
    after = [iou(e.box, box) > 0.3 for e, box in zip(estimates[47:], truth[48:], strict=True)]
    return sum(after) > len(after) / 2, estimates


COASTING = ParticleFilterConfig(
    particles=300, sigma=tuple(8 * s for s in RECOMMENDED_SIGMA), occlusion_ratio=0.7
)


def test_coasting_keeps_the_target_through_a_one_second_occlusion():
    runs = [kept_after_the_board(COASTING, seed) for seed in range(10)]
    assert sum(kept for kept, _ in runs) >= 9
    for _, estimates in runs:
        hidden = [e.hidden for e in estimates]
        assert all(hidden[31:39]), "taken as hidden while wholly behind the board"
        assert not any(hidden[:20]) and not any(hidden[50:]), "nor while in sight"
        # frames 32-40: the estimate goes on at about the walking speed (4 px per frame)
        advance = (estimates[39].box[0] - estimates[31].box[0]) / 8
        assert 3.0 < advance < 5.0


def test_in_perspective_scales_a_moved_box_about_its_bottom_centre():
    ground = ExpectedHeight(0.0, 0.5)  # h = 0.5 x bottom row
    before = np.array([[10.0, 100.0, 40.0, 100.0]])  # bottom row 200: 100 px expected
    moved = np.array([[10.0, 80.0, 40.0, 100.0]])  # its feet 20 rows up: 90 px expected
    np.testing.assert_allclose(in_perspective(moved, before, ground), [[12.0, 90.0, 36.0, 90.0]])
    np.testing.assert_allclose(in_perspective(before, before, ground), before)


def walker_who_vanishes(seed: int = 0):
    """A 30 x 80 px person walking 3 px/frame up the image (away from the camera) for 12 frames,
    then hidden (gone from the image) for 10."""
    rng = np.random.default_rng(seed)
    background = rng.integers(60, 160, size=(240, 200, 3), dtype=np.uint8)
    images, boxes = [], []
    for k in range(22):
        image = background.copy()
        y = 130 - 3 * k
        if k < 12:
            draw_person(image, 80, y)
        images.append(with_sensor_noise(image, rng))
        boxes.append(np.array([80.0, y, 30.0, 80.0]))
    return images, boxes


@pytest.mark.parametrize("perspective", [False, True])
def test_a_hidden_target_coasting_away_shrinks_with_the_ground_line(perspective: bool):
    """While hidden, the cloud's boxes move on at the speed seen; with `coast_perspective` they
    also shrink as their feet rise, as the ground line says (here h = 0.5 x the bottom row),
    instead of keeping the size they went out of sight with."""
    images, truth = walker_who_vanishes()
    ground = ExpectedHeight(0.0, 0.5)
    config = replace(COASTING, coast_perspective=perspective)
    f = ColourParticleFilter(
        images[0], truth[0], HistogramAppearance(), config, np.random.default_rng(0)
    )
    estimates = [f.step(image, height=ground) for image in images[1:]]
    hidden = [k for k, e in enumerate(estimates) if e.hidden]
    assert hidden and hidden == list(range(hidden[0], len(estimates))) and hidden[0] >= 10
    first, last = estimates[hidden[0]].box, estimates[-1].box
    assert last[1] + last[3] < first[1] + first[3] - 15, "coasting up the image"
    height_for_row = [box[3] / (box[1] + box[3]) for box in (first, last)]
    if perspective:
        assert height_for_row[1] == pytest.approx(height_for_row[0], rel=0.03)
    else:
        assert last[3] == pytest.approx(first[3], rel=0.03)


def walker_whose_legs_the_mask_loses(seed: int = 0):
    """The textured scene's 30 x 80 px person walking 4 px/frame right; from frame 5 on the
    foreground mask holds only their upper half (trousers that match the ground): images,
    masks and true boxes."""
    rng = np.random.default_rng(seed)
    background = rng.integers(60, 160, size=(200, 320, 3), dtype=np.uint8)
    images, masks, boxes = [], [], []
    for k in range(40):
        x, y = 20 + 4 * k, 60
        image = background.copy()
        draw_person(image, x, y)
        person = np.zeros(image.shape[:2], bool)
        person[y : y + (80 if k < 5 else 40), x : x + 30] = True
        images.append(with_sensor_noise(image, rng))
        masks.append(ForegroundMask.of(person))
        boxes.append(np.array([x, y, 30.0, 80.0]))
    return images, masks, boxes


@pytest.mark.parametrize("start_height", [False, True])
def test_before_a_ground_line_the_start_height_is_expected(start_height: bool):
    """With the height prior but no ground line yet (the step gets no `height`), the foreground
    cue pulls the box onto the half of the person the mask holds; with `height_before_line`
    the prior expects the start box's height wherever the box stands, and the box keeps it."""
    images, masks, truth = walker_whose_legs_the_mask_loses()
    config = replace(
        QUIET_COASTING_WITH_MASK,
        size_noise=0.05,
        height_spread=0.1,
        height_before_line=start_height,
    )
    for seed in range(3):
        f = ColourParticleFilter(
            images[0], truth[0], HistogramAppearance(), config, np.random.default_rng(seed)
        )
        steps = zip(images[1:], masks[1:], strict=True)
        estimates = [f.step(image, foreground=mask) for image, mask in steps]
        assert not any(e.hidden for e in estimates)
        heights = [e.box[3] for e in estimates[-10:]]
        assert abs(estimates[-1].box[0] - truth[-1][0]) < 10, "on the walker"
        if start_height:
            assert min(heights) > 0.9 * 80
        else:
            assert max(heights) < 0.75 * 80, "shrunk towards the half in the mask"


def turning_scene(seed: int = 0):
    """The textured scene's person walking 8 px/frame right who turns in their fourth frame: from
    then on the shirt shows another colour, and the person's box matches the start frame's
    reference at half of what the first frames scored."""
    rng = np.random.default_rng(seed)
    background = rng.integers(60, 160, size=(200, 480, 3), dtype=np.uint8)
    images, boxes = [], []
    for k in range(40):
        image = background.copy()
        x = 20 + 8 * k
        draw_person(image, x, 40, SHIRT if k < 3 else (40, 140, 230))
        images.append(with_sensor_noise(image, rng))
        boxes.append(np.array([x, 40.0, 30.0, 80.0]))
    return images, boxes


@pytest.mark.parametrize(("settle_frames", "kept_least", "kept_most"), [(0, 0, 1), (10, 9, 10)])
def test_a_target_is_not_taken_as_hidden_before_it_settles(
    settle_frames: int, kept_least: int, kept_most: int
):
    """The level a hidden target is judged by starts at the start frame's own match: a walker
    who turns a few steps on scores half of it, below the occlusion ratio, and without a settling
    time is taken as hidden on the spot, coasts at the speed of a cloud started at rest and is
    lost; given a second, the level comes down to what the person now scores."""
    images, truth = turning_scene()
    reference = HistogramAppearance(background_weighting=True)
    reference.reference(images[0], truth[0])
    assert reference.similarities(images[10], truth[10][None])[0] < 0.55
    config = replace(
        COASTING, sigma=tuple(16 * s for s in RECOMMENDED_SIGMA), settle_frames=settle_frames
    )
    kept = 0
    for seed in range(10):
        f = ColourParticleFilter(
            images[0],
            truth[0],
            HistogramAppearance(background_weighting=True),
            config,
            np.random.default_rng(seed),
        )
        steps = zip(images[1:], truth[1:], strict=True)
        overlaps = [iou(f.step(image).box, box) for image, box in steps]
        kept += np.mean(np.array(overlaps[-15:]) > 0.5) > 0.5
    assert kept_least <= kept <= kept_most


def test_a_quieter_coast_keeps_the_cloud_on_the_way_the_target_went():
    """With the noise that follows walkers (16 x the thesis's), a second of coasting at the full
    noise spreads the cloud over ~120 px (std), where a passer-by's scores outweigh the target's when
    it comes out; a quarter of that randomness while hidden (the noise, the velocities' spread)
    keeps it to a few tens."""
    images, truth = occluded_scene()
    wide = replace(COASTING, sigma=tuple(16 * s for s in RECOMMENDED_SIGMA))
    spreads = {}
    for coast_noise in (1.0, 0.25):
        config = replace(wide, coast_noise=coast_noise)
        f = ColourParticleFilter(
            images[0], truth[0], HistogramAppearance(), config, np.random.default_rng(0)
        )
        for image in images[1:39]:
            f.step(image)
        assert f.estimate.hidden
        spreads[coast_noise] = float(f.particles[:, 0].std())
    assert spreads[1.0] > 100 and spreads[0.25] < 0.4 * spreads[1.0]


def test_while_hidden_the_noise_is_coast_noise_times_sigma():
    images, truth = occluded_scene()
    config = replace(COASTING, coast_noise=0.25, adaptive_noise=False)
    f = ColourParticleFilter(
        images[0], truth[0], HistogramAppearance(), config, np.random.default_rng(0)
    )
    for image in images[1:34]:
        f.step(image)
    assert f.estimate.hidden
    np.testing.assert_allclose(f.noise(), 0.25 * np.array(config.sigma))


def test_after_the_warm_up_similarities_compile_nothing():
    """`colour_particles`'s `warm_up` (called by the node before it subscribes) compiles the
    coefficient kernel for the types every call passes."""
    from tracker_filter import colour_histograms

    colour_histograms.warm_up()
    before = len(colour_histograms._coefficients.signatures)
    rng = np.random.default_rng(0)
    image = rng.integers(0, 256, (60, 80, 3), dtype=np.uint8)
    for appearance in (HistogramAppearance(), HistogramAppearance(ColourSpace.HSV, regions=3)):
        appearance.reference(image, np.array([10.0, 10.0, 20.0, 30.0]))
        appearance.similarities(image, rng.uniform(0, 40, (50, 4)) + [0, 0, 5, 5])
    assert before == len(colour_histograms._coefficients.signatures) == 1
    rings = len(colour_histograms._ring_coefficients.signatures)
    contrasted = HistogramAppearance(contrast=1.0)
    contrasted.reference(image, np.array([10.0, 10.0, 20.0, 30.0]))
    contrasted.similarities(image, rng.uniform(0, 40, (50, 4)) + [0, 0, 5, 5])
    assert rings == len(colour_histograms._ring_coefficients.signatures) == 1


def test_the_coasting_velocity_is_the_mean_velocity_seen_from_the_first_frame():
    """A target hidden a few frames after its start coasts at the velocity it was seen moving
    at, not at a running mean still weighed towards the zero it started from."""
    images, truth = occluded_scene()
    f = ColourParticleFilter(
        images[0], truth[0], HistogramAppearance(), COASTING, np.random.default_rng(0)
    )
    velocities = [f.step(image).velocity for image in images[1:6]]
    np.testing.assert_allclose(f.seen_velocity, np.mean(velocities, axis=0))


def displaced_scene(drop: int = 160, seed: int = 0):
    """The textured scene's person walking 4 px/frame right behind a board (hidden wholly from
    frame 31 on) who comes out `drop` px lower than they went in, far off the way they went;
    images, foreground masks (the person's visible pixels) and true boxes."""
    rng = np.random.default_rng(seed)
    background = rng.integers(60, 160, size=(320, 320, 3), dtype=np.uint8)
    images, masks, boxes = [], [], []
    for k in range(60):
        x = 10 + 4 * k
        y = 30 + (drop if x >= 170 else 0)
        image = background.copy()
        person = np.zeros(image.shape[:2], bool)
        draw_person(image, x, y)
        person[y : y + 80, x : x + 30] = True
        image[20:140, 130:200] = (150, 150, 150)  # the board
        person[20:140, 130:200] = False
        images.append(with_sensor_noise(image, rng))
        masks.append(ForegroundMask.of(person))
        boxes.append(np.array([x, y, 30.0, 80.0]))
    return images, masks, boxes


#: the noise that follows walkers, a quarter of it while hidden, and the foreground cue on
QUIET_COASTING_WITH_MASK = replace(
    COASTING,
    sigma=tuple(16 * s for s in RECOMMENDED_SIGMA),
    coast_noise=0.25,
    foreground=ForegroundCue(power=15),
)


def test_probes_find_a_target_that_comes_out_off_its_way():
    """Coasting, the cloud follows the way the person went; one who comes out 2 heights
    lower is beyond its spread, and the filter stays 'hidden' while they walk on in sight.
    Probes on the foreground mask near the cloud find them as soon as they are back in it."""
    images, masks, truth = displaced_scene()
    wide = replace(QUIET_COASTING_WITH_MASK, size_noise=0.05)

    def found(config: ParticleFilterConfig, seed: int) -> int | None:
        f = ColourParticleFilter(
            images[0], truth[0], HistogramAppearance(), config, np.random.default_rng(seed)
        )
        frames = zip(images[1:], masks[1:], truth[1:], strict=True)
        for k, (image, mask, box) in enumerate(frames, 1):
            estimate = f.step(image, foreground=mask)
            if k > 40 and not estimate.hidden and iou(estimate.box, box) > 0.5:
                return k
        return None

    for seed in range(5):
        # the person is in sight again from frame 40
        with_probes = found(replace(wide, probes=50, probe_reach=2.5), seed)
        without = found(wide, seed)
        assert with_probes is not None and with_probes <= 42
        # without, the cloud's spread grows until a stray particle reaches them, 8-14 frames later
        assert without is None or without >= with_probes + 5


def test_a_hidden_target_reappears_only_where_the_mask_moves():
    """With `reappear_in_mask`, what ends a hidden spell must be in the detector's mask: a
    look-alike that does not move (here the person's own pixels with an empty mask, as a poster
    of them would be) leaves the target hidden; the same pixels in the mask bring it back."""
    images, masks, truth = displaced_scene(drop=0)
    config = replace(QUIET_COASTING_WITH_MASK, reappear_in_mask=True)
    empty = ForegroundMask.of(np.zeros(images[0].shape[:2], np.uint8))

    def hidden_after_the_board(config: ParticleFilterConfig, moving: bool) -> list[bool]:
        f = ColourParticleFilter(
            images[0], truth[0], HistogramAppearance(), config, np.random.default_rng(0)
        )
        for image, mask in zip(images[1:40], masks[1:40], strict=True):
            f.step(image, foreground=mask)
        assert f.estimate.hidden
        after = zip(images[40:50], masks[40:50], strict=True)
        return [f.step(image, foreground=mask if moving else empty).hidden for image, mask in after]

    assert all(hidden_after_the_board(config, moving=False))
    assert not all(hidden_after_the_board(config, moving=True))
    assert not all(hidden_after_the_board(replace(config, reappear_in_mask=False), moving=False))


def low_board_scene(seed: int = 0):
    """The textured scene's person walking right at 4 px/frame, who slows to 2 px/frame behind a
    low board that hides all but their top 30 px (of 80) from x 130 to 230; images, foreground
    masks (the person's visible pixels), their whole boxes and the visible ones."""
    rng = np.random.default_rng(seed)
    background = rng.integers(60, 160, size=(200, 320, 3), dtype=np.uint8)
    images, masks, whole, visible = [], [], [], []
    x = 10.0
    for _ in range(60):
        x += 4.0 if x < 130 else 2.0
        xi, y = round(x), 40
        image = background.copy()
        person = np.zeros(image.shape[:2], bool)
        draw_person(image, xi, y)
        person[y : y + 80, xi : xi + 30] = True
        image[70:200, 130:230] = (150, 150, 150)  # the board, up to the person's chest
        person[70:200, 130:230] = False
        images.append(with_sensor_noise(image, rng))
        masks.append(ForegroundMask.of(person))
        whole.append(np.array([xi, y, 30.0, 80.0]))
        rows, columns = np.nonzero(person)
        width, height = columns.max() + 1 - columns.min(), rows.max() + 1 - rows.min()
        visible.append(np.array([columns.min(), rows.min(), width, height], dtype=float))
    return images, masks, whole, visible


@pytest.mark.parametrize("upper_share", [0.0, 0.4])
def test_a_person_behind_a_low_board_is_followed_by_the_top_of_their_box(upper_share: float):
    """Behind a board up to their chest, the whole box no longer matches: without `upper_share`
    the target is taken as hidden and coasts at the 4 px/frame it went in at, ahead of the
    person, who slowed to 2. With it, the top part (shirt) still matches its own reference in
    the mask: the filter follows it, and reports the part in sight."""
    images, masks, whole, visible = low_board_scene()
    config = replace(QUIET_COASTING_WITH_MASK, upper_share=upper_share)
    behind = range(35, 50)  # frames wholly behind the board (the top part in sight)
    for seed in range(3):
        f = ColourParticleFilter(
            images[0], whole[0], HistogramAppearance(), config, np.random.default_rng(seed)
        )
        steps = zip(images[1:], masks[1:], strict=True)
        estimates = [None, *(f.step(image, foreground=mask) for image, mask in steps)]
        errors = [abs(estimates[k].box[0] - whole[k][0]) for k in behind]
        if upper_share:
            assert not any(estimates[k].hidden for k in behind)
            assert all(estimates[k].partial for k in behind)
            assert max(errors) < 6, "on the person's shirt"
            assert min(iou(estimates[k].box, visible[k]) for k in behind) > 0.6, "the part seen"
        else:
            assert all(estimates[k].hidden for k in behind)
            assert errors[-1] > 20, "coasting ahead of the person"


def test_a_part_alone_finds_a_hidden_target_only_at_its_usual_match():
    """After a full occlusion, the top part brings a hidden target back when it matches as well
    as it did while the target was seen whole; at 0.7 of that (enough for a target in sight) a
    part alone is not taken: a part is less telling than the whole."""
    images, masks, truth = displaced_scene(drop=0)
    f = ColourParticleFilter(
        images[0],
        truth[0],
        HistogramAppearance(),
        replace(QUIET_COASTING_WITH_MASK, upper_share=0.4),
        np.random.default_rng(0),
    )
    for image, mask in zip(images[1:41], masks[1:41], strict=True):
        f.step(image, foreground=mask)
    assert f.estimate.hidden and f.level and f.upper_level and f.upper
    boxes, image, mask = np.array([truth[50]]), images[50], masks[50]  # in sight again
    match = float(f.upper.similarities(image, top_parts(boxes, 0.4))[0])
    assert match > 0.5
    f.upper_level = 0.9 * match
    assert f._upper_scores(image, boxes, mask, best=0.0) is not None
    f.upper_level = 1.2 * match
    assert f._upper_scores(image, boxes, mask, best=0.0) is None
    f.estimate = replace(f.estimate, hidden=False)  # a target seen the frame before
    assert f._upper_scores(image, boxes, mask, best=0.0) is not None
    # not in the mask: a part that does not move is the board's, or a poster's
    empty = ForegroundMask.of(np.zeros(image.shape[:2], np.uint8))
    assert f._upper_scores(image, boxes, empty, best=0.0) is None


def test_top_parts_and_the_part_in_sight():
    boxes = np.array([[10.0, 20.0, 30.0, 80.0]])
    np.testing.assert_allclose(top_parts(boxes, 0.4), [[10.0, 20.0, 30.0, 32.0]])
    mask = np.zeros((200, 200), np.uint8)
    mask[20:70, 10:40] = 1  # the top 50 px of the box in sight
    np.testing.assert_allclose(
        seen_part(ForegroundMask.of(mask), boxes[0], 0.3, 0.4), [10, 20, 30, 50]
    )
    mask[:] = 0
    mask[20:25, 10:40] = 1  # a sliver: at least the top share is kept
    np.testing.assert_allclose(
        seen_part(ForegroundMask.of(mask), boxes[0], 0.3, 0.4), [10, 20, 30, 32]
    )
    empty = ForegroundMask.of(np.zeros((200, 200), np.uint8))
    np.testing.assert_allclose(seen_part(empty, boxes[0], 0.3, 0.4), boxes[0])
