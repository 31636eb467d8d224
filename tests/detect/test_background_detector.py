"""The background-mosaic detector (`tracker_detect.background.background`) scored box by box at IoU >= 0.5.

Ground truth is each object's *visible* box: the tight box of its pixels in the scene's label
image, inside the camera window. Blobs and visible boxes are matched one to one (Hungarian on
IoU); a match counts only at IoU >= 0.5, as MOTChallenge does. Scores are pooled over the frames
after the background has been learned.
"""

from __future__ import annotations

import re
from dataclasses import replace

import cv2
import numpy as np
import pytest
from box_scores import BoxScore

from tracker_detect.background import mosaic as mosaic_module
from tracker_detect.background.background import BackgroundConfig, BackgroundDetector
from tracker_detect.background.mosaic import SceneMosaic
from tracker_detect.detector import CameraFrame
from tracker_detect.registration import View
from tracker_msgs_py.geometry import Rect
from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

NS = 100_000_000
MIN_PIXELS = 60  # visible pixels an object needs to count
LEARNING_FRAMES = 10


def visible_boxes(labels: np.ndarray, x: int, y: int) -> list[Rect]:
    """Scene-pixel tight boxes of the objects with at least MIN_PIXELS pixels in `labels`."""
    boxes = []
    for object_id in np.unique(labels):
        if object_id == 0:
            continue
        ys, xs = np.nonzero(labels == object_id)
        if len(xs) >= MIN_PIXELS:
            boxes.append(
                Rect(x + xs.min(), y + ys.min(), xs.max() - xs.min() + 1, ys.max() - ys.min() + 1)
            )
    return boxes


def run(scene, windows, config=None, shakes=None) -> BoxScore:
    """Boxes scored after the learning frames; with `shakes`, frame k's image lands (dx, dy) px
    off the window its pose reports, and the truth is where the image really looks."""
    detector = BackgroundDetector(config or BackgroundConfig())
    score = BoxScore()
    for k, (x, y, w, h) in enumerate(windows):
        dx, dy = (0, 0) if shakes is None else shakes[k]
        ix, iy = x + dx, y + dy
        image = scene.frames[k, iy : iy + h, ix : ix + w]
        detection = detector.process(CameraFrame(k * NS, image, View(Rect(x, y, w, h), w, h)))
        if k >= LEARNING_FRAMES:
            truth = visible_boxes(scene.labels[k, iy : iy + h, ix : ix + w], ix, iy)
            score.add(truth, [b.bbox for b in detection.blobs])
    return score


def separate_walkers(seed: int, **overrides) -> SceneConfig:
    values = dict(
        width=480,
        height=320,
        num_frames=80,
        fps=10,
        num_objects=4,
        object_size_range=(20, 44),
        speed_range=(20, 50),
        turns=1,
        entries_exits=True,
        noise_sigma=3.0,
        illumination_drift=0.05,
        illumination_period=8.0,
        seed=seed,
    )
    values.update(overrides)
    return SceneConfig(**values)


@pytest.fixture(scope="module")
def scene():
    return generate_scene(separate_walkers(seed=41))


def test_static_camera_boxes_match_the_objects(scene):
    score = run(scene, [(0, 0, 480, 320)] * scene.num_frames)
    print(
        f"static: recall {score.recall:.3f} precision {score.precision:.3f} "
        f"mean IoU {score.mean_iou:.3f} ({score.matched}/{score.objects} objects)"
    )
    assert score.objects >= 150
    assert score.recall >= 0.85
    assert score.precision >= 0.85
    assert score.mean_iou >= 0.75


def test_moving_window_boxes_match_the_objects(scene):
    """The mosaic keeps the background in scene coordinates, so a sweeping window needs no
    learning time at places it has seen before."""
    n = scene.num_frames
    xs = (140 + 140 * np.sin(np.arange(n) / 8.0)).astype(int)
    windows = [(int(x), 40, 200, 240) for x in xs]
    score = run(scene, windows)
    print(
        f"moving: recall {score.recall:.3f} precision {score.precision:.3f} "
        f"mean IoU {score.mean_iou:.3f} ({score.matched}/{score.objects} objects)"
    )
    assert score.objects >= 80
    assert score.recall >= 0.75
    assert score.precision >= 0.8


def run_shaken(scene, config: BackgroundConfig, shake: int = 3) -> BoxScore:
    """A moving window whose image lands up to `shake` px off where its pose says (a camera on a
    mast in the wind), still for the learning frames."""
    rng = np.random.default_rng(5)
    n = scene.num_frames
    xs = (140 + 130 * np.sin(np.arange(n) / 8.0)).astype(int)  # the shaken image stays inside
    windows = [(int(x), 40, 200, 240) for x in xs]
    shakes = [
        (0, 0) if k < LEARNING_FRAMES else tuple(int(v) for v in rng.integers(-shake, shake + 1, 2))
        for k in range(n)
    ]
    return run(scene, windows, config, shakes)


def test_a_view_shaken_off_its_pose_is_aligned_with_the_background(scene):
    """Unreported shake of a few px makes the scene's edges foreground; aligned with the mosaic,
    the boxes match the objects where the image really looks."""
    trusted = run_shaken(scene, BackgroundConfig())
    aligned = run_shaken(scene, BackgroundConfig(register_reach=8))
    print(
        f"shaken: pose trusted recall {trusted.recall:.3f} precision {trusted.precision:.3f}; "
        f"aligned recall {aligned.recall:.3f} precision {aligned.precision:.3f} "
        f"mean IoU {aligned.mean_iou:.3f} ({aligned.matched}/{aligned.objects} objects)"
    )
    assert trusted.precision < 0.5
    assert aligned.recall >= 0.75
    assert aligned.precision >= 0.8
    assert aligned.mean_iou >= 0.7


@pytest.mark.parametrize("seed", [1, 2])
def test_a_large_mover_in_a_still_view_is_not_taken_for_shake(seed):
    """Big textured objects crossing a still camera's view can move the correlation peak (1-4
    frames of these scenes without the check that the aligned view fits the background better);
    the view stays at its pose."""
    scene = generate_scene(
        SceneConfig(
            width=320,
            height=240,
            num_frames=60,
            fps=10,
            num_objects=2,
            object_size_range=(100, 140),
            speed_range=(30, 60),
            noise_sigma=3.0,
            seed=seed,
        )
    )
    detector = BackgroundDetector(BackgroundConfig(register_reach=8))
    views = [
        detector.process(CameraFrame(k * NS, frame)).view.rect
        for k, frame in enumerate(scene.frames)
    ]
    assert all((r.x, r.y) == (0.0, 0.0) for r in views)


def test_register_reach_is_checked():
    with pytest.raises(ValueError, match="register_reach"):
        BackgroundConfig(register_reach=-1)


def test_the_seed_frame_difference_boxes_fail_iou():
    """Why the mosaic exists: a k - 3 difference blob covers the old and the new position."""
    from tracker_detect.motion.motion import DetectorConfig, MotionDetector

    scene = generate_scene(separate_walkers(seed=41, num_frames=40))
    detector = MotionDetector(DetectorConfig())
    score = BoxScore()
    for k in range(scene.num_frames):
        result = detector.process(cv2.cvtColor(scene.frames[k], cv2.COLOR_BGR2GRAY), k * NS)
        if k >= LEARNING_FRAMES:
            score.add(visible_boxes(scene.labels[k], 0, 0), [b.bbox for b in result.blobs])
    background = run(scene, [(0, 0, 480, 320)] * scene.num_frames)
    print(f"seed k-3 recall at IoU 0.5 {score.recall:.3f} vs mosaic {background.recall:.3f}")
    assert background.recall > score.recall + 0.3


def flickering_scene(frames: int = 90, seed: int = 5):
    """A static textured scene with a patch that changes every frame (tape, leaves) and, after
    frame 60, one object crossing it."""
    rng = np.random.default_rng(seed)
    base = cv2.GaussianBlur(rng.integers(0, 255, (240, 320), dtype=np.uint8), (0, 0), 2)
    images, boxes = [], []
    for k in range(frames):
        image = base.copy()
        image[40:100, 200:280] = cv2.GaussianBlur(
            rng.integers(0, 255, (60, 80), dtype=np.uint8), (0, 0), 1.5
        )
        box = None
        if k >= 60:
            x = 20 + 6 * (k - 60)
            image[140:190, x : x + 24] = 30
            box = Rect(x, 140, 24, 50)
        images.append(image)
        boxes.append(box)
    return images, boxes


def test_things_that_move_in_place_are_learned_and_ignored():
    images, boxes = flickering_scene()
    detector = BackgroundDetector()
    for k, image in enumerate(images):
        detection = detector.process(CameraFrame(k * NS, image))
        if k >= 60:
            assert len(detection.blobs) == 1, f"frame {k}: {[b.bbox for b in detection.blobs]}"
            assert detection.blobs[0].bbox.iou(boxes[k]) >= 0.5
    seed_style = BackgroundDetector(BackgroundConfig(flicker_level=1.0))
    flicker_blobs = 0
    for k, image in enumerate(images):
        detection = seed_style.process(CameraFrame(k * NS, image))
        flicker_blobs += sum(1 for b in detection.blobs if b.bbox.x >= 190 and b.bbox.y < 110)
    assert flicker_blobs >= 40  # without the flicker map the patch is "motion" in every frame


def test_flat_blobs_are_dropped_when_min_aspect_is_set():
    """A standing object (24 x 50) and a strip lying flat (60 x 8, like barrier tape blown
    along) both move: with min_aspect 0.5 only the standing one is a blob."""
    rng = np.random.default_rng(3)
    base = cv2.GaussianBlur(rng.integers(0, 255, (240, 320), dtype=np.uint8), (0, 0), 2)
    standing = BackgroundDetector(BackgroundConfig(min_aspect=0.5))
    everything = BackgroundDetector()
    for k in range(40):
        image = base.copy()
        x = 20 + 5 * k
        image[140:190, x : x + 24] = 30
        image[40:48, x + 10 : x + 70] = 220
        kept = standing.process(CameraFrame(k * NS, image))
        found = everything.process(CameraFrame(k * NS, image))
        if k >= 25:  # the first frame's ghosts have healed
            assert [b.bbox.iou(Rect(x, 140, 24, 50)) >= 0.5 for b in kept.blobs] == [True]
            assert any(b.bbox.y < 60 and b.bbox.height < b.bbox.width / 2 for b in found.blobs)


def asphalt() -> np.ndarray:
    """Faintly textured grey-green ground, 320 x 240, BGR."""
    rng = np.random.default_rng(4)
    grey = cv2.GaussianBlur(rng.integers(100, 140, (240, 320), dtype=np.uint8), (0, 0), 2)
    return np.dstack([grey, (grey * 1.1).clip(0, 255).astype(np.uint8), grey])


def with_cast_shadow(ground: np.ndarray, x: int, rows: slice) -> np.ndarray:
    """A copy of `ground` darkened to 0.7 (its colour kept) in `rows`, from x + 10 to x + 60: the
    shadow of a walker at x, cast to its right at the feet."""
    image = ground.copy()
    shadow = (rows, slice(x + 10, x + 60))
    image[shadow] = (image[shadow] * 0.7).astype(np.uint8)
    return image


def test_cast_shadows_are_not_objects_when_shadow_ratio_is_set():
    """A red walker (24 x 50) on faintly textured grey-green ground (asphalt) casts a shadow to
    its right at the feet (the ground darkened to 0.7, its colour kept): with shadow_ratio 0.5 the blob is the
    walker; without, the shadow widens it past IoU 0.5. A dark grey coat over the same ground
    is darker *and* of another colour: still an object. (min_aspect drops the flat ghosts the
    coat leaves where it stood in the first frames.)"""
    ground = asphalt()
    with_shadows = BackgroundDetector(BackgroundConfig(shadow_ratio=0.5, min_aspect=0.5))
    without = BackgroundDetector(BackgroundConfig(min_aspect=0.5))
    for k in range(40):
        x = 20 + 5 * k
        image = with_cast_shadow(ground, x, rows=slice(175, 190))
        image[140:190, x : x + 24] = (40, 40, 200)  # BGR: red
        image[60:100, 280 - 3 * k : 300 - 3 * k] = (25, 25, 25)  # the dark coat
        kept = with_shadows.process(CameraFrame(k * NS, image))
        found = without.process(CameraFrame(k * NS, image))
        if k >= 25:
            walker, coat = Rect(x, 140, 24, 50), Rect(280 - 3 * k, 60, 20, 40)
            assert sorted(
                round(max(b.bbox.iou(t) for t in (walker, coat))) for b in kept.blobs
            ) == [1, 1]
            assert max(b.bbox.iou(walker) for b in found.blobs) < 0.5


def stopping_walker(k: int, ground: np.ndarray) -> tuple[np.ndarray, Rect]:
    """Frame k of a walker (24 x 50, red clothes with a coarse weave) crossing `ground` who
    stands still from frame 20 to 69 (5 s at 10 frames/s), and its box."""
    weave = np.random.default_rng(8).integers(0, 60, (50, 24, 1), dtype=np.uint8)
    x = 20 + 4 * (min(k, 20) + max(k - 69, 0))
    image = ground.copy()
    image[140:190, x : x + 24] = np.array([20, 20, 150], np.uint8) + weave  # BGR: red
    return image, Rect(x, 140, 24, 50)


def test_a_person_who_stops_stays_foreground_with_a_stopped_heal_rate():
    """Still pixels heal into the background at heal_rate (0.05 per frame): someone who stops
    for 5 s is gone from the mask within about 2 s. With `stopped_heal_rate` 0.005 a still blob
    whose outline is an edge of the view (not of the background) heals ten times slower: the
    walker is found at IoU >= 0.5 through the whole stop, and leaves no ghost when they walk on."""
    ground = asphalt()
    plain = BackgroundDetector(BackgroundConfig(min_aspect=0.5))
    holding = BackgroundDetector(BackgroundConfig(min_aspect=0.5, stopped_heal_rate=0.005))
    plain_found, held_found, held_other = [], [], []
    for k in range(100):
        image, walker = stopping_walker(k, ground)
        plain_blobs = plain.process(CameraFrame(k * NS, image)).blobs
        held_blobs = holding.process(CameraFrame(k * NS, image)).blobs
        plain_found.append(any(b.bbox.iou(walker) >= 0.5 for b in plain_blobs))
        held_found.append(any(b.bbox.iou(walker) >= 0.5 for b in held_blobs))
        held_other.append(sum(b.bbox.iou(walker) < 0.5 for b in held_blobs))
    assert all(held_found[22:]), "lost while standing or after walking on"
    assert sum(held_other[22:]) == 0, "a ghost where the walker stood"
    assert not any(plain_found[45:70])


EMPTY_FRAMES = 60


def bush(ground: np.ndarray) -> np.ndarray:
    """`ground` with a bush behind where `stopping_walker` stands: dark and bright leaves, as
    edged as the walker's outline (x 80-160, y 120-200)."""
    rng = np.random.default_rng(6)
    leaves = cv2.GaussianBlur(rng.integers(0, 255, (80, 80), dtype=np.uint8), (0, 0), 1.5)
    leaves = cv2.normalize(leaves, None, 20, 235, cv2.NORM_MINMAX)
    image = ground.copy()
    image[120:200, 80:160] = np.dstack([leaves // 2, leaves, leaves // 2])  # green
    return image


def test_a_person_who_stops_before_a_bush_stays_foreground():
    """Before foliage the background's edges along the walker's outline are as strong as the
    walker's, so the outline alone does not tell a stopped person from a ghost; the long-term
    background (the bush, seen before the walker came) does: held through the stop, and no
    ghost of them when they walk on."""
    ground = bush(asphalt())
    holding = BackgroundDetector(BackgroundConfig(min_aspect=0.5, stopped_heal_rate=0.005))
    for k in range(EMPTY_FRAMES):  # the place seen empty first, as a camera on duty has
        holding.process(CameraFrame(k * NS, ground))
    found, other = [], []
    for k in range(100):
        image, walker = stopping_walker(k, ground)
        blobs = holding.process(CameraFrame((EMPTY_FRAMES + k) * NS, image)).blobs
        found.append(any(b.bbox.iou(walker) >= 0.5 for b in blobs))
        other.append(sum(b.bbox.iou(walker) < 0.5 for b in blobs))
    assert all(found[22:]), "lost while standing before the bush or after walking on"
    assert sum(other[22:]) == 0, "a ghost where the walker stood"


@pytest.mark.parametrize("stopped_heal_rate", [0.05, 0.005])
def test_a_ghost_of_an_object_seen_at_start_fades(stopped_heal_rate):
    """An object present in the first frames is learned as background; once it leaves, its old
    place differs from the mosaic but does not change, and heals. Also when stopped objects are
    held: the long-term background learned the object too, so its ghost differs from both
    backgrounds, but its outline is the background's."""
    rng = np.random.default_rng(3)
    base = cv2.GaussianBlur(rng.integers(0, 255, (160, 200), dtype=np.uint8), (0, 0), 2)
    detector = BackgroundDetector(BackgroundConfig(stopped_heal_rate=stopped_heal_rate))
    ghosts = []
    for k in range(60):
        image = base.copy()
        if k < 10:
            image[60:110, 40:70] = 220
        detection = detector.process(CameraFrame(k * NS, image))
        ghosts.append(len(detection.blobs))
    assert sum(ghosts[10:14]) >= 1  # the ghost appears when the object leaves
    assert ghosts[40:] == [0] * 20


def test_mosaic_sample_returns_what_was_learned_anywhere_in_the_scene():
    rng = np.random.default_rng(0)
    scene = rng.integers(0, 255, (300, 400), dtype=np.uint8)
    mosaic = SceneMosaic(warmup_observations=1)
    for x, y in ((0, 0), (150, 100), (300, 200), (20, 180)):
        view = View(Rect(x, y, 100, 100), 100, 100)
        crop = scene[y : y + 100, x : x + 100]
        mosaic.update(view, crop, np.ones((100, 100)), np.zeros((100, 100)))
        sample = mosaic.sample(view)
        assert np.allclose(sample.mean, crop, atol=1e-3)
        assert (sample.observations >= 1).all()
    # A zoomed view (2 scene px per image px) samples the same place at half resolution.
    view = View(Rect(150, 100, 100, 100), 50, 50)
    zoomed = mosaic.sample(view).mean
    expected = cv2.resize(scene[100:200, 150:250].astype(np.float32), (50, 50), cv2.INTER_AREA)
    assert np.abs(zoomed - expected).mean() < 40  # bilinear point samples of a noise image
    assert np.corrcoef(zoomed.ravel(), expected.ravel())[0, 1] > 0.3


@pytest.mark.parametrize("border", [cv2.BORDER_CONSTANT, cv2.BORDER_REPLICATE])
@pytest.mark.parametrize("channels", [1, 2, 3])
def test_a_whole_pixel_view_is_copied_exactly_as_the_interpolation_samples_it(border, channels):
    """`_warp`'s shortcut (a pixel-aligned view inside the layer: a copy) gives the bilinear
    warp's values bit for bit; a shift that is not whole, or reaches outside, still warps."""
    rng = np.random.default_rng(3)
    layer = rng.random((90, 120, channels)).astype(np.float32).squeeze()
    for shift in ((7.0, 11.0), (0.0, 0.0), (40.0, 30.0), (7.5, 11.0), (100.0, 5.0)):
        matrix = np.array([[1.0, 0.0, shift[0]], [0.0, 1.0, shift[1]]])
        expected = cv2.warpAffine(
            layer, matrix, (80, 60), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
            borderMode=border, borderValue=0.0,
        )  # fmt: skip
        assert np.array_equal(mosaic_module._warp(layer, matrix, (80, 60), border), expected)
    assert mosaic_module._aligned(np.array([[1.0, 0, 7], [0, 1.0, 11]]), (80, 60), (90, 120))
    assert (
        mosaic_module._aligned(np.array([[1.0, 0, 7.5], [0, 1.0, 11]]), (80, 60), (90, 120)) is None
    )
    assert (
        mosaic_module._aligned(np.array([[2.0, 0, 7], [0, 2.0, 11]]), (40, 30), (90, 120)) is None
    )
    assert (
        mosaic_module._aligned(np.array([[1.0, 0, 41], [0, 1.0, 0]]), (80, 60), (90, 120)) is None
    )


@pytest.mark.parametrize("with_chroma", [False, True])
def test_the_compiled_blend_is_the_update_rule_in_float32(with_chroma):
    """`_blend` against the rule written out in NumPy (float32 throughout), on mosaic slices."""
    rng = np.random.default_rng(4)
    shape, area = (70, 90), (slice(5, 65), slice(10, 80))
    mean = rng.random(shape).astype(np.float32) * 255
    count = rng.integers(0, 30, shape).astype(np.float32)
    flicker = rng.random(shape).astype(np.float32)
    chroma = rng.random((*shape, 2)).astype(np.float32)
    seen = rng.random((60, 70, 3)).astype(np.float32) * np.float32(255)
    seen[..., 1] = np.where(rng.random((60, 70)) < 0.4, 0.0, 0.05)  # rate: 0 under movers
    seen[..., 2] = rng.random((60, 70)) < 0.2  # changing
    inside = rng.random((60, 70)) < 0.9
    seen_chroma = rng.random((60, 70, 2)).astype(np.float32)
    warmup, memory = 20, 100.0

    expected = [a.copy() for a in (mean, count, flicker, chroma)]
    m, n, f, c = (a[area] for a in expected)
    n += inside
    rate = seen[..., 1]
    first = np.where((rate > 0) | (n <= 1), np.maximum(1.0 / np.maximum(n, 1.0), rate), 0.0)
    blend = np.where(n <= warmup, first, rate) * inside
    m += blend * (seen[..., 0] - m)
    if with_chroma:
        c += blend[..., None] * (seen_chroma - c)
    f += inside * (seen[..., 2] - f) / np.minimum(np.maximum(n, 1.0), memory)

    got = [a.copy() for a in (mean, count, flicker, chroma)]
    mosaic_module._blend(
        got[0][area], got[1][area], got[2][area], got[3][area] if with_chroma else None,
        seen, inside, seen_chroma if with_chroma else None, warmup, np.float32(memory),
    )  # fmt: skip
    for a, b in zip(got, expected, strict=True):
        assert a.dtype == np.float32 and np.array_equal(a, b)


def test_learning_after_the_detections_are_out_changes_nothing(scene):
    """A node lets the background learn a frame after publishing its detections
    (`learn_last_frame`); left to the next `process`, or done at once, every frame gives the same
    blobs and masks, also across a reconfiguration (learned with the config it was detected
    with), and the models end up the same. `reset` forgets a frame not learned yet."""
    config = BackgroundConfig(min_aspect=0.5, stopped_heal_rate=0.005, register_reach=4)
    changed = replace(config, learning_rate=0.2, heal_rate=0.1)
    n = scene.num_frames
    xs = (140 + 140 * np.sin(np.arange(n) / 8.0)).astype(int)
    lazy, eager = BackgroundDetector(config), BackgroundDetector(config)
    for k, x in enumerate(xs):
        image = scene.frames[k, 40:280, x : x + 200]
        frame = CameraFrame(k * NS, image, View(Rect(int(x), 40, 200, 240), 200, 240))
        if k == n // 2:
            lazy.reconfigure(changed)
            eager.reconfigure(changed)
        left, done = lazy.process(frame), eager.process(frame)
        eager.learn_last_frame()
        assert [b.bbox for b in left.blobs] == [b.bbox for b in done.blobs], f"frame {k}"
        assert np.array_equal(left.mask, done.mask)
    lazy.learn_last_frame()
    whole = View(Rect(0, 0, 480, 320), 480, 320)
    for learned, model in ((lazy.mosaic, eager.mosaic), (lazy.long_term, eager.long_term)):
        assert np.array_equal(learned.sample(whole).mean, model.sample(whole).mean)
        assert np.array_equal(learned.sample(whole).flicker, model.sample(whole).flicker)
    eager.process(
        CameraFrame(n * NS, scene.frames[-1, 40:280, 0:200], View(Rect(0, 40, 200, 240), 200, 240))
    )
    eager.reset()
    eager.learn_last_frame()
    assert not eager.mosaic.sample(whole).observations.any()


def test_a_view_the_mosaic_cannot_hold_is_refused_before_anything_changes():
    """A pose far off the scene or a window of absurd size would need a mosaic of TiB: the frame
    is refused (UnusableViewError, naming the size) and the next frames detect as if it had never
    come."""
    from tracker_detect.background.background import MAX_MOSAIC_PIXELS
    from tracker_detect.detector import UnusableViewError

    rng = np.random.default_rng(1)
    ground = cv2.GaussianBlur(rng.integers(0, 255, (90, 120), dtype=np.uint8), (5, 5), 1.5)
    mosaic = SceneMosaic()
    assert mosaic.pixels_covering(View(Rect(0, 0, 120, 90), 120, 90)) == 120 * 90

    def frames(bad: bool):
        for k in range(30):
            image = ground.copy()
            image[30:60, 10 + 3 * k : 22 + 3 * k] = 20
            if bad and k == 20:
                for far in (
                    Rect(1e6, 1e6, 120, 90),
                    Rect(-1e5, -1e5, 120, 90),
                    Rect(0, 0, 1e5, 7.5e4),
                ):
                    yield CameraFrame(k * 10**8 + 1, image, View(far, 120, 90)), True
            yield CameraFrame(k * 10**8 + 2, image, View(Rect(0, 0, 120, 90), 120, 90)), False

    def boxes(bad: bool) -> list[list[Rect]]:
        detector, found = BackgroundDetector(BackgroundConfig()), []
        for frame, refused in frames(bad):
            if refused:
                with pytest.raises(
                    UnusableViewError, match=re.escape(f"at most {MAX_MOSAIC_PIXELS:.3g}")
                ):
                    detector.process(frame)
                continue
            found.append([b.bbox for b in detector.process(frame).blobs])
        return found

    clean = boxes(False)
    assert boxes(True) == clean and any(clean[-5:])
