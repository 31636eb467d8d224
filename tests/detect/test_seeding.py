"""SeededSession: a seeded detector's start (initial region), hand-over policy, guidance and
pass-through, image by image, on a test-only detector that reports its region."""

from __future__ import annotations

import numpy as np
import pytest
from region_detector import RegionDetector

from tracker_detect.detector import CameraFrame
from tracker_detect.seeding import Guidance, Offer, SeededSession, SeedingConfig
from tracker_msgs_py.geometry import Rect

NS = 100_000_000  # 10 fps
BOX = Rect(100, 50, 20, 40)


def frame(k: int) -> CameraFrame:
    return CameraFrame(k * NS, np.zeros((240, 320, 3), np.uint8))


def offer(k: int, box: Rect = BOX, measured: bool = True, hits: int = 10) -> Offer:
    return Offer(k * NS, 3, box, measured, hits)


def boxes(step) -> list[Rect]:
    return [b.bbox for b in step.detection.blobs]


def test_the_initial_region_starts_it_on_the_first_image_only():
    session = SeededSession(RegionDetector(), initial_region=BOX)
    first = session.step(frame(0))
    assert first.initial == "tracking started" and boxes(first) == [BOX]
    assert session.step(frame(1)).initial is None


@pytest.mark.parametrize(
    "offered, taken",
    [
        (offer(0), True),
        (offer(0, measured=False), False),  # a coasting prediction
        (offer(0, hits=4), False),  # a young track (handover_min_hits 5)
    ],
)
def test_an_offer_is_made_only_of_a_measured_settled_target(offered, taken):
    session = SeededSession(RegionDetector())
    step = session.step(frame(0), offered)
    assert (step.offer is not None and step.offer.taken) is taken
    assert boxes(step) == ([BOX] if taken else [])


def test_no_offer_without_handover_and_a_refusal_names_its_reason():
    session = SeededSession(RegionDetector(), SeedingConfig(handover=False))
    assert session.step(frame(0), offer(0)).offer is None
    refusing = SeededSession(RegionDetector())
    step = refusing.step(frame(0), offer(0, box=Rect(5, 5, 0, 10)))
    assert step.offer is not None and not step.offer.taken
    assert step.offer.refused == "the region is empty"


def test_an_offer_to_a_tracking_detector_is_its_to_judge():
    session = SeededSession(RegionDetector(), initial_region=BOX)
    session.step(frame(0))
    step = session.step(frame(1), offer(1, box=Rect(200, 50, 20, 40)))
    assert step.offer is not None and not step.offer.taken and step.offer.refused is None
    assert boxes(step) == [BOX]


def test_guidance_moves_the_search_to_the_predicted_position_when_fresh():
    session = SeededSession(RegionDetector(), initial_region=BOX)
    session.step(frame(0))
    guide = Guidance(0, 150.0, 100.0, 20.0, -10.0)  # px, px/s at frame 0
    [moved] = boxes(session.step(frame(1), guide=guide))
    assert moved.center == pytest.approx((152.0, 99.0))  # 0.1 s later
    stale = Guidance(0, 10.0, 10.0, 0.0, 0.0)
    [kept] = boxes(session.step(frame(9), guide=stale))  # 0.9 s old > guide_max_age 0.5
    assert kept == moved


def test_the_image_of_a_hand_over_is_not_guided_by_the_old_target():
    session = SeededSession(RegionDetector())
    old_target = Guidance(0, 300.0, 200.0, 0.0, 0.0)
    [box] = boxes(session.step(frame(1), offer(1), old_target))
    assert box == BOX


def test_pass_through_reports_the_measured_offer_until_the_detector_has_a_target():
    detector = RegionDetector()
    detector.hand_over = lambda region, frame: "not yet"  # type: ignore[method-assign]
    session = SeededSession(detector, SeedingConfig(handover_passthrough=True))
    [blob] = session.step(frame(0), offer(0)).detection.blobs
    assert blob.bbox == BOX and blob.score == 0.0
    assert session.step(frame(1), offer(1, measured=False)).detection.blobs == []
    plain = SeededSession(RegionDetector(), SeedingConfig(handover=False))
    assert plain.step(frame(0), offer(0)).detection.blobs == []


def test_the_source_track_measured_apart_from_the_detectors_box_starts_it_there_again():
    """The detector drifted (its box stayed behind) while the track that started it still measures
    the walker elsewhere: started again on the track's box. Another track's box is the detector's
    to judge (RegionDetector refuses it while tracking), and so is the source track once
    handover_follow_source is off."""
    session = SeededSession(RegionDetector())
    session.step(frame(0), offer(0))  # started from track 3
    walked_on = Rect(200, 60, 20, 40)
    other = Offer(NS, 8, walked_on, True, 10)
    assert not session.step(frame(1), other).offer.taken
    step = session.step(frame(2), Offer(2 * NS, 3, walked_on, True, 10))
    assert step.offer.taken and step.offer.again and boxes(step) == [walked_on]
    fixed = SeededSession(RegionDetector(), SeedingConfig(handover_follow_source=False))
    fixed.step(frame(0), offer(0))
    assert not fixed.step(frame(1), offer(1, box=walked_on)).offer.taken
