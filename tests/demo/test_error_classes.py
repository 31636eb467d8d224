"""Each in-view miss and false box put in one class (evaluation.error_classes)."""

from tracker_msgs_py.geometry import Rect
from tracker_ptz_sim.evaluation.error_classes import error_classes, frame_errors

PERSON = Rect(100.0, 100.0, 40.0, 100.0)


def test_each_kind_of_miss_is_told_apart():
    legs_lost = Rect(100.0, 100.0, 40.0, 45.0)  # IoU 0.45, 0.45 x the area
    sign_joined = Rect(100.0, 20.0, 40.0, 180.0)  # IoU 0.56: still a match
    with_tape = Rect(90.0, 60.0, 70.0, 140.0)  # IoU 0.41, 2.45 x the area
    shifted = Rect(125.0, 100.0, 40.0, 100.0)  # IoU 0.23, same area
    assert frame_errors([PERSON], [PERSON], [PERSON], []) == {}
    assert frame_errors([PERSON], [], [PERSON], [PERSON]) == {"tentative_track": 1}
    assert frame_errors([PERSON], [], [PERSON], []) == {"not_reported": 1}
    assert frame_errors([PERSON], [], [legs_lost], []) == {"detection_too_small": 1}
    assert frame_errors([PERSON], [], [with_tape], []) == {"detection_too_big": 1}
    assert frame_errors([PERSON], [], [shifted], []) == {"detection_off": 1}
    assert frame_errors([PERSON], [], [Rect(400.0, 100.0, 40.0, 100.0)], []) == {"no_detection": 1}
    assert frame_errors([PERSON], [sign_joined], [sign_joined], []) == {}
    # two people walking close, one box over both: it matches one, the other is missed
    beside = Rect(110.0, 100.0, 40.0, 100.0)
    pair = Rect(100.0, 100.0, 50.0, 100.0)
    assert frame_errors([PERSON, beside], [pair], [pair], []) == {"shared_box": 1}


def test_false_boxes_on_a_person_and_on_nothing():
    half = Rect(100.0, 100.0, 40.0, 45.0)
    tape = Rect(300.0, 50.0, 30.0, 12.0)
    counts = frame_errors([PERSON], [half, tape], [half, tape], [])
    assert counts == {"detection_too_small": 1, "overlaps_person": 1, "on_nothing": 1}
    assert frame_errors([], [tape], [tape], []) == {"on_nothing": 1}


def test_a_run_sums_its_frames_and_names_every_class():
    truth = {1: {7: PERSON}, 2: {7: PERSON}}
    reported = {1: {3: PERSON}, 2: {3: Rect(300.0, 50.0, 30.0, 12.0)}}
    detections = {1: [PERSON], 2: [PERSON]}
    totals = error_classes(truth, reported, detections, {}, [1, 2, 3])
    assert totals["people"] == 2 and totals["reported"] == 2
    assert totals["not_reported"] == 1 and totals["on_nothing"] == 1
    assert totals["no_detection"] == 0 and totals["tentative_track"] == 0
