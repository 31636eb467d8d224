"""The `byte` tracker against scenes whose people are known: ids through a crossing, weak boxes
that only continue tracks, a false box that never becomes one, a person found again by their
colours after being hidden, and the box filter's equations."""

from __future__ import annotations

import numpy as np
import pytest

from tracker_filter.byte.byte_tracker import (
    BoxKalman,
    ByteConfig,
    ByteTracker,
    appearance,
    similarity,
)
from tracker_filter.observation import Detections, Observation
from tracker_filter.tracking import TrackStatus
from tracker_msgs_py.geometry import Rect

DT = 0.1
WINDOW = Rect(0.0, 0.0, 320.0, 240.0)  # the image is the scene


def boxes_at(boxes: list[tuple[float, float, float, float]], scores: list[float]) -> Detections:
    b = np.array(boxes, float).reshape(-1, 4)
    return Detections(b[:, :2] + b[:, 2:] / 2, b[:, 2] * b[:, 3], b, np.array(scores, float))


def run(tracker: ByteTracker, frames: list[Detections], images=None) -> list:
    out = []
    for k, detections in enumerate(frames):
        image = None if images is None else images[k]
        out.append(tracker.step(Observation(k * DT, detections, True, image, None, WINDOW)))
    return out


def ids_of(track_set, box) -> int:
    """The confirmed track whose box overlaps `box` most."""
    best, chosen = 0.0, -1
    for report in track_set:
        if report.status in (TrackStatus.CONFIRMED, TrackStatus.COASTING):
            overlap = Rect(*report.bbox).iou(Rect(*box))
            if overlap > best:
                best, chosen = overlap, report.id
    return chosen


def test_two_people_crossing_keep_their_ids():
    """Left walks right, right walks left; at the crossing one box hides the other for 3 frames."""
    tracker = ByteTracker(ByteConfig(refind_similarity=0.0))
    frames, truth = [], []
    for k in range(30):
        a = (20.0 + 8 * k, 100.0, 20.0, 60.0)
        b = (260.0 - 8 * k, 104.0, 20.0, 60.0)
        truth.append((a, b))
        hidden = 14 <= k <= 16
        frames.append(boxes_at([b] if hidden else [a, b], [0.8] if hidden else [0.8, 0.8]))
    sets = run(tracker, frames)
    first = ids_of(sets[5], truth[5][0]), ids_of(sets[5], truth[5][1])
    last = ids_of(sets[29], truth[29][0]), ids_of(sets[29], truth[29][1])
    assert -1 not in first and first == last


def test_weak_boxes_continue_a_track_but_never_start_one():
    tracker = ByteTracker(ByteConfig(refind_similarity=0.0))
    walker = [(50.0 + 5 * k, 80.0, 20.0, 60.0) for k in range(12)]
    frames = []
    for k, box in enumerate(walker):
        score = 0.3 if 6 <= k <= 9 else 0.9  # half hidden: the model is unsure
        frames.append(boxes_at([box, (250.0, 20.0, 15.0, 40.0)], [score, 0.3]))  # + a weak thing
    sets = run(tracker, frames)
    ids = {ids_of(s, box) for s, box in zip(sets[3:], walker[3:], strict=True)}
    assert len(ids) == 1 and -1 not in ids
    assert all(len(s) == 1 for s in sets)  # the weak thing on its own never became a track


def test_a_lone_false_box_never_becomes_a_track():
    tracker = ByteTracker(ByteConfig(confirm_hits=3, refind_similarity=0.0))
    frames = [boxes_at([(100.0, 100.0, 20.0, 50.0)], [0.9])] + [Detections.empty()] * 3
    sets = run(tracker, frames)
    assert [len(s) for s in sets] == [1, 1, 0, 0]  # reported tentative once, then LOST, then gone
    assert sets[1].report(0).status == TrackStatus.LOST


def coloured_scene(people: list[tuple[tuple[float, float, float, float], tuple[int, int, int]]]):
    image = np.full((240, 320, 3), 128, np.uint8)
    for (x, y, w, h), colour in people:
        image[int(y) : int(y + h / 2), int(x) : int(x + w)] = colour  # coat
        image[int(y + h / 2) : int(y + h), int(x) : int(x + w)] = (40, 40, 40)  # trousers
    return image


@pytest.mark.parametrize("refind", [0.0, 0.8])
def test_a_person_hidden_and_turning_is_found_again_by_their_colours(refind):
    """A red-coated person walks right, is hidden for 6 frames (behind the sign) and comes out
    having stopped: the constant-velocity box has gone on without them. A blue-coated person
    stands nearby all along. With colours the red person keeps their id; without, they get a
    new one."""
    tracker = ByteTracker(ByteConfig(refind_similarity=refind, max_misses=20))
    red, blue = (0, 0, 220), (220, 0, 0)
    frames, images, boxes = [], [], []
    for k in range(24):
        x = 40.0 + 10 * min(k, 10)  # walks until frame 10, then stands
        person = (x, 90.0, 24.0, 70.0)
        other = (230.0, 95.0, 24.0, 70.0)
        hidden = 10 <= k <= 15
        shown = [(other, blue)] if hidden else [(person, red), (other, blue)]
        images.append(coloured_scene(shown))
        frames.append(boxes_at([b for b, _ in shown], [0.9] * len(shown)))
        boxes.append(person)
    sets = run(tracker, frames, images)
    before, after = ids_of(sets[8], boxes[8]), ids_of(sets[20], boxes[20])
    assert before != -1 and after != -1
    assert (before == after) == (refind > 0)
    assert bool(tracker.needs) == (refind > 0)  # colours need the camera image


def test_appearance_tells_coats_apart_and_likes_itself():
    image = coloured_scene(
        [((10.0, 10.0, 30.0, 80.0), (0, 0, 220)), ((60.0, 10.0, 30.0, 80.0), (220, 0, 0))]
    )
    looks = appearance(image, np.array([[10.0, 10.0, 30.0, 80.0], [60.0, 10.0, 30.0, 80.0]]))
    alike = similarity(looks, looks)
    assert np.allclose(np.diag(alike), 1.0)
    assert alike[0, 1] < 0.6  # the same trousers, other coats


def test_the_box_filter_follows_a_box_moving_at_constant_velocity():
    """After a few updates of a box moving 40 px/s, the prediction a frame ahead is on it
    (the filter's velocity converges: x = F x with F = [[I, dt I], [0, I]])."""
    kalman = BoxKalman(0.05, 0.00625)
    kalman.add(np.array([[0.0, 0.0, 20.0, 50.0]]), DT)
    for k in range(1, 30):
        kalman.predict(DT)
        kalman.update(np.array([0]), np.array([[4.0 * k, 0.0, 20.0, 50.0]]))
    kalman.predict(DT)
    assert kalman.boxes()[0] == pytest.approx([120.0, 0.0, 20.0, 50.0], abs=0.5)
    assert kalman.means[0, 4] == pytest.approx(40.0, abs=1.0)  # px/s


@pytest.mark.parametrize(("distance", "same"), [(60.0, True), (250.0, False)])
def test_a_look_alike_is_found_again_only_within_a_walkers_reach(distance, same):
    """A red-coated person (70 px tall) standing at the left is hidden for 1 s; then a red coat
    shows `distance` px from where they stood. 60 px is within a walker's reach in that time
    (`refind_reach` 1.5 heights a second: 115 px): the same person, their id. 250 px is not:
    someone else in the same colours, a new track, though the old one is still kept."""
    tracker = ByteTracker(ByteConfig(refind_similarity=0.8, max_misses=20))
    red = (0, 0, 220)
    frames, images = [], []
    for k in range(22):
        if k < 6:
            shown = [((40.0, 90.0, 24.0, 70.0), red)]
        elif k < 16:
            shown = []
        else:
            shown = [((40.0 + distance, 90.0, 24.0, 70.0), red)]
        images.append(coloured_scene(shown))
        frames.append(boxes_at([b for b, _ in shown], [0.9] * len(shown)))
    sets = run(tracker, frames, images)
    before = ids_of(sets[5], (40.0, 90.0, 24.0, 70.0))
    after = ids_of(sets[21], (40.0 + distance, 90.0, 24.0, 70.0))
    assert before != -1 and after != -1
    assert (before == after) == same
