"""Motion mask, morphology, blobs and the MotionDetector's bookkeeping."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy import ndimage

from tracker_detect.blobs import components, fill_holes, find_blobs, largest_blob, presence_test
from tracker_detect.motion.motion import (
    SEED_KERNEL,
    DetectorConfig,
    MotionDetector,
    StaleFrameError,
    motion_mask,
    structuring_element,
)
from tracker_detect.registration import View
from tracker_msgs_py.geometry import Rect

NS = 100_000_000  # 10 fps


def test_seed_kernel_is_the_thesis_element():
    rows = ["0001000", "0111110", "0111110", "1111111", "0111110", "0111110", "0001000"]
    expected = np.array([[int(c) for c in row] for row in rows], np.uint8)
    np.testing.assert_array_equal(SEED_KERNEL, expected)
    np.testing.assert_array_equal(structuring_element("seed", 99), expected)
    assert structuring_element("ellipse", 5).shape == (5, 5)
    with pytest.raises(ValueError):
        structuring_element("ellipse", 4)
    with pytest.raises(ValueError):
        structuring_element("star", 5)


def test_fill_holes_matches_scipy_on_random_masks():
    rng = np.random.default_rng(0)
    for density in (0.3, 0.5, 0.7):
        mask = (rng.random((60, 80)) < density).astype(np.uint8)
        expected = ndimage.binary_fill_holes(mask).astype(np.uint8)  # 4-connected background
        np.testing.assert_array_equal(fill_holes(mask), expected)


def test_fill_holes_fills_a_ring_but_not_an_open_c():
    ring = np.zeros((20, 20), np.uint8)
    cv2.rectangle(ring, (4, 4), (15, 15), 1, thickness=2)
    assert fill_holes(ring)[10, 10] == 1
    open_c = ring.copy()
    open_c[9:11, 13:18] = 0
    assert fill_holes(open_c)[10, 10] == 0


def test_motion_mask_thresholds_then_applies_the_steps_in_order():
    similarity = np.ones((40, 40), np.float32)
    similarity[20, 20] = 0.5  # exactly the threshold counts as motion (seed: SSIM <= 0.5)
    similarity[5, 5] = 0.51
    bare = motion_mask(similarity, 0.5, steps=())
    assert bare.sum() == 1 and bare[20, 20] == 1
    seed = motion_mask(similarity, 0.5)  # fill, dilate, fill, dilate with H
    twice = cv2.dilate(cv2.dilate(bare, SEED_KERNEL), SEED_KERNEL)
    np.testing.assert_array_equal(seed, twice)
    with pytest.raises(ValueError, match="unknown morphology"):
        motion_mask(similarity, 0.5, steps=("blur",))


def test_blobs_in_scene_coordinates_with_pixel_centre_convention():
    mask = np.zeros((30, 40), np.uint8)
    mask[2:6, 3:5] = 1  # 4 x 2 pixels: centre of mass at (4.0, 4.0) in corner coordinates
    mask[10:20, 20:30] = 1
    mask[20, 30] = 1  # touches only diagonally: a separate blob with 4-connectivity
    similarity = np.where(mask > 0, 0.2, 1.0).astype(np.float32)
    similarity[10:20, 20:25] = 0.4
    view = View(Rect(100.0, 50.0, 80.0, 60.0), 40, 30)  # 2 scene px per image px
    blobs = find_blobs(mask, similarity, view)
    assert [b.pixel_count for b in blobs] == [100, 8, 1]  # largest first
    big, small, dot = blobs
    assert (big.centroid_x, big.centroid_y) == pytest.approx((100 + 2 * 25.0, 50 + 2 * 15.0))
    assert big.bbox == Rect(140.0, 70.0, 20.0, 20.0)
    assert big.area == pytest.approx(400.0)
    assert big.score == pytest.approx(0.3)
    assert (small.centroid_x, small.centroid_y) == pytest.approx((108.0, 58.0))
    assert dot.bbox == Rect(160.0, 90.0, 2.0, 2.0)
    assert largest_blob(blobs) is big
    assert len(find_blobs(mask, similarity, view, connectivity=8)) == 2
    assert find_blobs(np.zeros((5, 5), np.uint8), np.ones((5, 5)), View.identity(5, 5)) == []


@pytest.mark.parametrize("connectivity", [4, 8])
def test_components_are_opencvs_labels_boxes_and_centroids(connectivity):
    """`components` (and `find_blobs` on it) give what cv2.connectedComponentsWithStats gives:
    the same labels, boxes, areas and centroids to the last bit, and the SSIM sums of one
    bincount over the whole image."""
    rng = np.random.default_rng(connectivity)
    for _ in range(40):
        mask = (ndimage.uniform_filter(rng.random((48, 64)), 3) > 0.55).astype(np.uint8)
        similarity = rng.random(mask.shape).astype(np.float32)
        count, labels, stats, centroids = cv2.connectedComponentsWithStats(
            mask, connectivity=connectivity, ltype=cv2.CV_32S
        )
        parts = components(mask, connectivity)
        assert parts.count == count and np.array_equal(parts.labels, labels)
        assert [parts.box(k) for k in range(1, count)] == [
            tuple(stats[k, :4]) for k in range(1, count)
        ]
        sums = np.bincount(labels.ravel(), weights=similarity.ravel(), minlength=count)
        blobs = find_blobs(mask, similarity, View.identity(64, 48), connectivity)
        expected = sorted(
            (
                (
                    int(stats[k, 4]),
                    float(centroids[k, 0] + 0.5),
                    float(centroids[k, 1] + 0.5),
                    float(sums[k] / stats[k, 4]),
                )
                for k in range(1, count)
            ),
            key=lambda e: (-e[0], e[2], e[1]),
        )
        assert [(b.pixel_count, b.centroid_x, b.centroid_y, b.score) for b in blobs] == expected
    assert components(np.zeros((5, 5), np.uint8)).slices == []


def test_presence_test_is_0_08_percent_of_the_compared_area():
    assert presence_test(8, 10_000)
    assert not presence_test(7, 10_000)
    assert not presence_test(0, 10_000)
    assert not presence_test(5, 0)


def textured(shape, seed):
    rng = np.random.default_rng(seed)
    noise = cv2.GaussianBlur(rng.standard_normal(shape).astype(np.float32), (0, 0), 1.5)
    return np.clip(128 + 60 * noise / noise.std(), 0, 255).astype(np.uint8)


def square_clip(positions, size=(80, 100), square=12):
    """Grey frames of a static texture with a textured square at each (x, y)."""
    background = textured(size, 1)
    patch = textured((square, square), 2) // 2 + 100
    frames = []
    for x, y in positions:
        frame = background.copy()
        frame[y : y + square, x : x + square] = patch
        frames.append(frame)
    return frames


def test_detector_waits_for_gap_frames_then_finds_the_mover():
    frames = square_clip([(10 + 4 * k, 30) for k in range(8)])
    detector = MotionDetector(DetectorConfig(gap=3))
    results = [detector.process(f, k * NS) for k, f in enumerate(frames)]
    assert [r.compared for r in results] == [False] * 3 + [True] * 5
    assert all(not r.target_present and not r.blobs for r in results[:3])
    for k, r in enumerate(results[3:], start=3):
        assert r.target_present
        target = r.blobs[0]
        # the blob spans the square's old and new position (the seed's frame-difference blob)
        assert target.bbox.x <= 10 + 4 * (k - 3) and target.bbox.x + target.bbox.width >= 22 + 4 * k
        assert r.compared_area == 80 * 100 and r.ego_shift == (0.0, 0.0)
        assert r.mask.shape == r.similarity.shape == (80, 100)


def test_static_scene_has_no_detection():
    frames = square_clip([(30, 30)] * 6)
    detector = MotionDetector()
    results = [detector.process(f, k * NS) for k, f in enumerate(frames)]
    assert all(r.blobs == [] and not r.target_present for r in results)


def test_stale_stamps_are_rejected_without_touching_the_history():
    frames = square_clip([(10 + 4 * k, 30) for k in range(6)])
    detector = MotionDetector(DetectorConfig(gap=2))
    for k in range(3):
        detector.process(frames[k], k * NS)
    with pytest.raises(StaleFrameError):
        detector.process(frames[3], 2 * NS)  # duplicate
    with pytest.raises(StaleFrameError):
        detector.process(frames[3], 1 * NS)  # out of order
    assert detector.history_length == 2
    result = detector.process(frames[3], 3 * NS)
    assert result.compared and result.target_present


def test_bad_images_raise_and_keep_state():
    detector = MotionDetector()
    detector.process(square_clip([(10, 10)])[0], 0)
    with pytest.raises(ValueError):
        detector.process(np.zeros((80, 100, 3), np.uint8), NS)
    with pytest.raises(ValueError):
        detector.process(np.full((80, 100), np.nan), NS)
    with pytest.raises(ValueError, match="view"):
        detector.process(np.zeros((80, 100), np.uint8), NS, View.identity(50, 50))
    assert detector.history_length == 1


def test_image_size_change_resets_the_history():
    detector = MotionDetector(DetectorConfig(gap=1))
    small = square_clip([(10, 10), (14, 10)], size=(60, 60))
    big = square_clip([(10, 10), (14, 10)], size=(80, 100))
    assert detector.process(small[0], 0).compared is False
    assert detector.process(small[1], NS).compared is True
    changed = detector.process(big[0], 2 * NS)
    assert changed.history_reset and not changed.compared
    assert detector.process(big[1], 3 * NS).compared


def test_reconfigure_keeps_what_history_it_can():
    frames = square_clip([(10 + 4 * k, 30) for k in range(6)])
    detector = MotionDetector(DetectorConfig(gap=3))
    for k in range(4):
        detector.process(frames[k], k * NS)
    detector.reconfigure(DetectorConfig(gap=1, threshold=0.4))
    assert detector.history_length == 1
    assert detector.process(frames[4], 4 * NS).compared


@pytest.mark.parametrize(
    "bad",
    [
        {"gap": 0},
        {"threshold": 1.5},
        {"morphology": ("fill", "smooth")},
        {"kernel_size": 4},
        {"connectivity": 6},
        {"compensation": "magic"},
        {"min_overlap_fraction": 0.0},
    ],
)
def test_config_validation(bad):
    with pytest.raises(ValueError):
        DetectorConfig(**bad)


def test_double_detection_keeps_a_stopped_object():
    """The square moves until frame 7, then stops: only the double detection still sees it."""
    positions = [(8 + 5 * k, 30) for k in range(8)] + [(43, 30)] * 12
    frames = square_clip(positions)
    plain = MotionDetector(DetectorConfig(gap=3))
    double = MotionDetector(DetectorConfig(gap=3, double_detection=True, reference_max_age=30))
    stopped_at = 7  # positions[7] == positions[8] == ...
    for k, frame in enumerate(frames):
        a = plain.process(frame, k * NS)
        b = double.process(frame, k * NS)
        if k >= stopped_at + 3:  # the gap comparison no longer sees any change
            assert not a.target_present
            assert b.target_present
            x, y = positions[k]
            assert any(blob.bbox.contains(x + 6.0, y + 6.0) for blob in b.blobs), (
                "the stopped square is not covered"
            )
        elif k >= 3:
            assert a.target_present and b.target_present


def test_double_detection_reference_expires():
    positions = [(8 + 5 * k, 30) for k in range(8)] + [(43, 30)] * 12
    detector = MotionDetector(DetectorConfig(gap=3, double_detection=True, reference_max_age=5))
    results = [detector.process(f, k * NS) for k, f in enumerate(square_clip(positions))]
    assert not results[-1].target_present


def test_change_map_is_the_similarity_process_gives_without_the_blobs():
    frames = square_clip([(10 + 4 * k, 30) for k in range(8)])
    processed, mapped = MotionDetector(DetectorConfig(gap=3)), MotionDetector(DetectorConfig(gap=3))
    for k, frame in enumerate(frames):
        similarity = processed.process(frame, k * NS).similarity
        change = mapped.change_map(frame, k * NS)
        assert (change is None) == (similarity is None) == (k < 3)
        if change is not None:
            assert np.array_equal(change, similarity)
