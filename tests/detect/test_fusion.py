"""The person_motion detector: motion proposes, the person model decides."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from tracker_detect.detector import Blob, CameraFrame
from tracker_detect.person.fusion import (
    FusionConfig,
    FusionDetector,
    moving_shares,
    unexplained,
    vouched_scores,
)
from tracker_detect.person.person import PersonConfig
from tracker_msgs_py.geometry import Rect


def blob(x, y, w, h, score=0.2, label="motion"):
    return Blob(x + w / 2, y + h / 2, Rect(x, y, w, h), w * h, int(w * h), score, label=label)


def test_a_blob_the_people_cover_is_theirs_and_the_rest_is_motion():
    pair = blob(100, 100, 40, 60)
    flag = blob(300, 50, 20, 20, score=0.3)
    people = [blob(100, 100, 20, 60, 0.8, "person"), blob(120, 100, 20, 60, 0.7, "person")]
    left = unexplained([pair, flag], people, 0.5)
    assert len(left) == 1 and left[0].bbox == flag.bbox
    assert left[0].label == "motion" and left[0].score == pytest.approx(0.7)  # 1 - mean SSIM


def test_motion_vouches_for_a_box_or_caps_its_score():
    mask = np.zeros((100, 100), np.uint8)
    mask[10:50, 10:30] = 1
    boxes = np.array([[10, 10, 30, 50, 0.9], [60, 10, 80, 50, 0.9], [60, 60, 80, 90, 0.3]])
    np.testing.assert_allclose(moving_shares(boxes, mask), [1.0, 0.0, 0.0])
    config = FusionConfig(motion_share=0.05, still_score=0.45)
    np.testing.assert_allclose(vouched_scores(boxes, mask, config), [0.9, 0.45, 0.3])


def cut_out_person(video):
    """A whole, tall person of vtest.avi (frame 100) and the clip's first frame around them."""
    from tracker_ptz_sim.bringup.benchmark import CLIPS
    from tracker_ptz_sim.simulation.frame_sources import video_frames
    from tracker_ptz_sim.simulation.ground_truth import read_tracks

    frame = next(itertools.islice(video_frames(video), 99, None))
    boxes = read_tracks(CLIPS["vtest"].gt).in_frame(100).values()
    best = max((b for b in boxes if b.visibility >= 1.0), key=lambda b: b.h)
    x, y, w, h = (round(v) for v in (best.x, best.y, best.w, best.h))
    return frame[y : y + h, x : x + w].copy()


def test_a_still_person_shape_is_never_confident_and_a_walker_is(vtest_clip):
    """A person pasted in place from the first frame (a poster, a statue, a sign the model takes
    for a person) and the same person walking: the model finds both, motion vouches only for the
    walker, so only the walker's box stays confident (the byte tracker starts tracks only from
    those)."""
    person = cut_out_person(vtest_clip)
    h, w = person.shape[:2]
    rng = np.random.default_rng(3)
    ground = rng.integers(90, 110, (264, 264, 3), dtype=np.uint8)
    detector = FusionDetector(FusionConfig())
    walker_scores, still_scores = [], []
    for k in range(30):
        image = ground.copy()
        image[20 : 20 + h, 10 : 10 + w] = person  # still, from the first frame on
        x = 100 + 4 * k
        image[120 : 120 + h, x : x + w] = person
        detection = detector.process(CameraFrame(1 + k * 100_000_000, image))
        if k < 10:
            continue
        for b in detection.blobs:
            if b.label != "person":
                continue
            centre_y = b.bbox.y + b.bbox.height / 2
            (walker_scores if centre_y > 120 else still_scores).append(b.score)
    assert len(walker_scores) >= 15 and min(walker_scores) > 0.5
    assert len(still_scores) >= 15 and max(still_scores) <= 0.45


def test_the_model_beside_the_motion_detector_gives_the_model_s_own_boxes(vtest_clip):
    """The model runs on a thread of its own while the motion detector works: every person box
    is the one the model alone finds on that image, and a frame the motion detector refuses (a
    stale one) raises its error and leaves the next frame as good."""
    from tracker_detect.detector import StaleFrameError
    from tracker_detect.person.person import PersonModel
    from tracker_ptz_sim.simulation.frame_sources import video_frames

    config = PersonConfig(score_threshold=0.2)
    detector = FusionDetector(FusionConfig(person=config, still_score=1.0))
    alone = PersonModel(config)
    frames = itertools.islice(video_frames(vtest_clip), 0, 40, 4)
    for k, frame in enumerate(frames):
        image = frame[100:298, 200:464].copy()
        if k == 5:
            with pytest.raises(StaleFrameError):
                detector.process(CameraFrame(1 + (k - 1) * 100_000_000, image))  # k = 4 again
        detection = detector.process(CameraFrame(1 + k * 100_000_000, image))
        people = sorted(
            (b.bbox.x, b.bbox.y, b.score) for b in detection.blobs if b.label == "person"
        )
        expected = sorted(
            (max(0.0, float(b[0])), max(0.0, float(b[1])), float(b[4])) for b in alone.detect(image)
        )
        np.testing.assert_allclose(people, expected, atol=1e-4)


def test_a_frame_the_motion_detector_refuses_is_reported_with_its_cause(monkeypatch):
    """A stale frame the model also fails on raises the motion detector's error (the cause), not
    the model's, and the next frame is processed as usual."""
    from tracker_detect.detector import StaleFrameError

    detector = FusionDetector(FusionConfig(person=PersonConfig()))
    image = np.full((198, 264, 3), 100, np.uint8)
    detector.process(CameraFrame(200_000_000, image))

    def broken(_image):
        raise RuntimeError("the model cannot read this frame")

    monkeypatch.setattr(detector.model, "detect", broken)
    with pytest.raises(StaleFrameError):
        detector.process(CameraFrame(100_000_000, image))
    monkeypatch.undo()
    assert detector.process(CameraFrame(300_000_000, image)).compared
